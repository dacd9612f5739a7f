"""Python attribute names for ROS field names."""

from __future__ import annotations

import keyword


def attribute_name(field_name: str) -> str:
    """The attribute holding a field: its name, with ``_`` appended to Python keywords."""
    if keyword.iskeyword(field_name):
        return field_name + '_'
    return field_name
