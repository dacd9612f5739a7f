"""The errors of the bag package, in one module (each is importable as ``zros.bag.<Name>``)."""

from __future__ import annotations

from pathlib import Path

from zros.errors import ZrosError


class BagError(ZrosError):
    """A bag cannot be opened or read: the message names the file and the cause."""

    def __init__(self, path: str | Path, reason: str) -> None:
        super().__init__(f'{path}: {reason}')
        self.path = Path(path)
        self.reason = reason


class AddressError(ZrosError, ValueError):
    """A field address (``/topic/field/path``) that names no numeric field or no known topic
    (``Bag.columns``, ``zros plot``: ``zros.plot.PlotError`` is this class)."""


class BagWriteError(ZrosError):
    """A bag cannot be created or written (the folder exists, a bad split setting...)."""


class RecorderError(ZrosError):
    """A recording cannot start (nothing selected, a bad regex) or failed while writing."""


class PlayerError(ZrosError):
    """A bag cannot be played as asked (unknown topics, a bad rate or offset...)."""


class Unsupported(Exception):
    """A storage cannot be read in bulk (chunks, rows); read it message by message instead."""
