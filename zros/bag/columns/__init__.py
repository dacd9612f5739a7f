"""Numeric fields of many messages as numpy columns, read straight from the CDR bytes."""
