"""The error of bag reading."""

from __future__ import annotations

from pathlib import Path

from zros.errors import ZrosError


class BagError(ZrosError):
    """A bag cannot be opened or read: the message names the file and the cause."""

    def __init__(self, path: str | Path, reason: str) -> None:
        super().__init__(f'{path}: {reason}')
        self.path = Path(path)
        self.reason = reason
