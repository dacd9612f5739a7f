"""The root of every exception zros raises."""

from __future__ import annotations


class ZrosError(Exception):
    """Base class of all zros errors."""
