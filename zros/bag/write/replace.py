"""A file rewritten beside itself and renamed over the original once complete and on disk."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from zros.bag.errors import BagError

#: the name of the file being written beside ``name``
TEMPORARY = '.{}.reindex'


def temporary_of(file: Path) -> Path:
    """The hidden file a rewrite of ``file`` is written into."""
    return file.with_name(TEMPORARY.format(file.name))


@contextmanager
def replacing(file: Path) -> Iterator[Path]:
    """The path to write ``file``'s new content to: fsynced and renamed over ``file`` when the
    block ends, removed when it raises (then the original is unchanged; an ``OSError`` becomes
    a :class:`BagError` saying so)."""
    temporary = temporary_of(file)
    try:
        yield temporary
        with temporary.open('rb+') as stream:
            os.fsync(stream.fileno())
        os.replace(temporary, file)
    except BaseException as exc:
        temporary.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise BagError(file, f'cannot rewrite it ({exc}); the original is unchanged') from exc
        raise
