"""Reading recordings raw: the formats (one module each), the table that picks one, their shapes."""
