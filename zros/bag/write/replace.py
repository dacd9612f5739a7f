"""A file rewritten beside itself and renamed over the original once complete and on disk."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from zros.bag.errors import BagError
from zros.bag.read.rosbag2 import BACKUP_MARK
from zros.version import counted

#: the name of the file being written beside ``name``
TEMPORARY = '.{}.reindex'


def temporary_of(file: Path) -> Path:
    """The hidden file a rewrite of ``file`` is written into."""
    return file.with_name(TEMPORARY.format(file.name))


def backup_of(file: Path) -> Path:
    """Where the original of ``file`` is kept: ``NAME.orig.EXT`` (as ROS 1's ``rosbag
    reindex``), or ``NAME.orig-2.EXT``... when that exists (an earlier backup is never
    overwritten)."""
    number = 1
    while True:
        mark = BACKUP_MARK if number == 1 else f'{BACKUP_MARK}-{number}'
        backup = file.with_name(f'{file.stem}{mark}{file.suffix}')
        if not backup.exists():
            return backup
        number += 1


@contextmanager
def replacing(file: Path, backup: Path | None = None) -> Iterator[Path]:
    """The path to write ``file``'s new content to: fsynced and renamed over ``file`` when the
    block ends, removed when it raises (then the original is unchanged; an ``OSError`` becomes
    a :class:`BagError` saying so). With ``backup``, the original is kept there first."""
    temporary = temporary_of(file)
    kept = False
    try:
        yield temporary
        with temporary.open('rb+') as stream:
            os.fsync(stream.fileno())
        if backup is not None:
            kept = True
            try:
                os.link(file, backup)  # no copy where the file system allows
            except OSError:
                shutil.copy2(file, backup)
        os.replace(temporary, file)
    except BaseException as exc:
        temporary.unlink(missing_ok=True)
        if kept and backup is not None:  # the original is still in place
            backup.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise BagError(file, f'cannot rewrite it ({exc}); the original is unchanged') from exc
        raise


def lost_words(count: int) -> str:
    """A count of messages a rewrite could not keep, in words (-1: unknown)."""
    return 'an unknown number of messages' if count < 0 else counted(count, 'message')
