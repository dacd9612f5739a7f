"""The root of every exception zros raises."""

from __future__ import annotations


class ZrosError(Exception):
    """Base class of all zros errors."""


class SettingError(ZrosError, ValueError):
    """A setting that cannot work as given (a usage error: the ``zros`` command exits with 2)."""
