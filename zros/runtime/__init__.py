"""The runtime core every entity stands on: waking, executor, clock and time, logging, timers,
the node context entities get from their node, and the one entity base."""
