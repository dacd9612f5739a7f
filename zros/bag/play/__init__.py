"""Playing a bag into the live graph: the player, its clock, its topics."""
