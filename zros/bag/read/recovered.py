"""What the readers of damaged or unfinished files share with rosbags' storage readers."""

from __future__ import annotations

from collections.abc import Collection, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.rosbag2.metadata import ReaderMetadata


class StorageReader(Protocol):
    """What zros reads of one storage file's reader: rosbags' (McapReader, Sqlite3Reader) or
    a :class:`Recovered` one (whose ``metadata`` is None until it is open)."""

    @property
    def connections(self) -> list[Connection]:
        """The file's connections (after ``open``)."""
        ...

    @property
    def metadata(self) -> ReaderMetadata | None:
        """Counts and times of the file's messages (after ``open``)."""
        ...

    def open(self) -> None:
        """Open the file."""
        ...

    def close(self) -> None:
        """Close the file."""
        ...

    def messages(
        self, connections: Collection[Connection], start: int | None = None, stop: int | None = None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """(connection, time, data) of ``connections`` in time order."""
        ...


class SqlCursor(Protocol):
    """The rows of a query (sqlite3's or apsw's cursor)."""

    def __iter__(self) -> Iterator[tuple[int, int, int, bytes]]: ...

    def fetchone(self) -> tuple[int, ...] | None:
        """The next row, or None."""
        ...


class SqlConnection(Protocol):
    """A database connection (sqlite3's or apsw's)."""

    def execute(self, sql: str, args: Sequence[object], /) -> SqlCursor:
        """Run a query."""
        ...


class SqlStorageReader(StorageReader, Protocol):
    """A db3 file's reader: rosbags' Sqlite3Reader (once open) or RecoveredDb3."""

    @property
    def dbconn(self) -> SqlConnection:
        """The open database."""
        ...


class Recovered:
    """A storage read around its damage (``connections`` set by its ``open``), with the
    ``messages`` of rosbags' readers."""

    connections: list[Connection]

    def messages(
        self,
        connections: Collection[Connection] = (),
        start: int | None = None,
        stop: int | None = None,
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """(connection, time, data) of ``connections`` (default all) with ``start <= time <
        stop``, in time order."""
        by_id = {c.id: c for c in connections or self.connections}
        return self._select(by_id, start, stop)

    def _select(
        self, by_id: dict[int, Connection], start: int | None, stop: int | None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        raise NotImplementedError


def path_of(reader: StorageReader) -> Path:
    """A storage reader's file (rosbags' declared reader protocol does not name it)."""
    return Path(str(getattr(reader, 'path', '')))


def within(stamp: int, start: int | None, stop: int | None) -> bool:
    """Whether ``start <= stamp < stop`` (None: unbounded)."""
    return (start is None or stamp >= start) and (stop is None or stamp < stop)
