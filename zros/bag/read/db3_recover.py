"""A ``.db3`` whose SQLite pages are damaged, read row by row around them.

rosbags opens a db3 by counting its messages, a query over the whole table that fails on the
first damaged page ("database disk image is malformed"). Here the messages table is read in
ranges of row ids; a range that fails is halved until the rows that cannot be read are single
ids, which are reported as lost rows. The class has the interface of rosbags' storage readers,
so :mod:`zros.bag.read.rosbag2` treats it like one.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.read.recovered import Recovered, within

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.rosbag2.metadata import ReaderMetadata

#: the first bytes of every SQLite database file
MAGIC = b'SQLite format 3\x00'
_RANGE = 4096
_FORMATS = {'ros2msg': 'MSG', 'ros2idl': 'IDL'}
Row = tuple[int, int, int, bytes]  #: (row id, topic id, timestamp, data)


def is_sqlite(path: Path) -> bool:
    """Whether the file starts with the SQLite magic."""
    with path.open('rb') as stream:
        return stream.read(len(MAGIC)) == MAGIC


class RecoveredDb3(Recovered):
    """The rows of a damaged db3 that read, as a rosbags-like storage. After :meth:`open`,
    ``lost_rows`` lists the row ids that could not be read."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.dbconn = sqlite3.connect(f'file:{path}?mode=ro', uri=True)
        self.connections: list[Connection] = []
        self.msgtypes: list[dict[str, str]] = []
        self.metadata: ReaderMetadata | None = None
        self.lost_rows: list[int] = []
        self._rows: list[tuple[int, int, int]] = []  #: (timestamp, row id, topic id), in time order

    def open(self) -> None:
        """Read the topics and definitions, then every row that reads (their times and ids)."""
        from rosbags.interfaces import (  # noqa: PLC0415 (lazy: rosbags, import time)
            Connection,
            ConnectionExtRosbag2,
            MessageDefinition,
            MessageDefinitionFormat,
        )
        from rosbags.rosbag2.metadata import ReaderMetadata, parse_qos  # noqa: PLC0415 (lazy: rosbags, import time)

        try:
            topics = self.dbconn.execute(
                'SELECT id, name, type, serialization_format, offered_qos_profiles FROM topics'
            ).fetchall()
        except sqlite3.OperationalError:  # a schema before QoS profiles
            topics = [
                (*row, '')
                for row in self.dbconn.execute(
                    'SELECT id, name, type, serialization_format FROM topics'
                )
            ]
        try:
            self.msgtypes = [
                {'name': name, 'encoding': encoding, 'msgdef': text}
                for name, encoding, text in self.dbconn.execute(
                    'SELECT topic_type, encoding, encoded_message_definition '
                    'FROM message_definitions'
                )
            ]
        except sqlite3.DatabaseError:  # no such table (before Iron), or damaged: the registry
            self.msgtypes = []
        counts: dict[int, int] = {}
        for stamp, row, topic in self._scan():
            counts[topic] = counts.get(topic, 0) + 1
            self._rows.append((stamp, row, topic))
        self._rows.sort()
        for cid, name, msgtype, serialization, qos in topics:
            known = next((m for m in self.msgtypes if m['name'] == msgtype), None)
            form = _FORMATS.get(known['encoding'], 'NONE') if known else 'NONE'
            self.connections.append(
                Connection(
                    cid,
                    name,
                    msgtype,
                    MessageDefinition(
                        MessageDefinitionFormat[form], known['msgdef'] if known else ''
                    ),
                    '',
                    counts.get(cid, 0),
                    ConnectionExtRosbag2(serialization, parse_qos(qos) if qos else []),
                    self,  # a reader in all but name
                )
            )
        count = len(self._rows)
        first = self._rows[0][0] if count else 0
        last = self._rows[-1][0] + 1 if count else 0
        self.metadata = ReaderMetadata(last - first, first, last, count, None, None, None, None)

    def _scan(self) -> Iterator[tuple[int, int, int]]:
        """(timestamp, row id, topic id) of every row that reads, the others in lost_rows."""
        top, exact = self._last_id()
        todo = [(low, min(low + _RANGE, top + 1)) for low in range(1, top + 1, _RANGE)]
        seen: set[int] = set()
        while todo:
            low, high = todo.pop(0)
            try:
                found = self.dbconn.execute(
                    'SELECT timestamp, id, topic_id FROM messages WHERE id >= ? AND id < ?',
                    (low, high),
                ).fetchall()
            except sqlite3.DatabaseError:
                if high - low == 1:
                    self.lost_rows.append(low)
                else:
                    middle = (low + high) // 2
                    todo[:0] = [(low, middle), (middle, high)]
                continue
            for stamp, row, topic in found:
                if not low <= row < high:
                    continue  # a damaged page that parses into rows that were never written
                seen.add(row)
                if isinstance(stamp, int) and isinstance(topic, int):
                    yield stamp, row, topic
                else:  # a damaged page that still parses: no time or topic to read it by
                    self.lost_rows.append(row)
        if exact:  # rosbag2 numbers its rows from 1 and deletes none: a missing one was lost
            seen.update(self.lost_rows)
            self.lost_rows += [row for row in range(1, top + 1) if row not in seen]
        self.lost_rows.sort()

    def _last_id(self) -> tuple[int, bool]:
        """The last row id, and whether it is known (else a bound from the file size)."""
        try:
            (top,) = self.dbconn.execute('SELECT max(id) FROM messages').fetchone()
        except sqlite3.DatabaseError:  # the damage is on the way to the last row
            return max(1, self.path.stat().st_size // 16), False  # a row takes over 16 bytes
        return int(top or 0), True

    def close(self) -> None:
        """Close the database."""
        self.dbconn.close()

    def _select(
        self, by_id: dict[int, Connection], start: int | None, stop: int | None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        for stamp, row, topic in self._rows:
            if topic in by_id and within(stamp, start, stop):
                try:
                    found = self.dbconn.execute(
                        'SELECT data FROM messages WHERE id = ?', (row,)
                    ).fetchone()
                except sqlite3.DatabaseError:
                    continue  # read at open, not now: the file changed
                if found is not None:
                    yield by_id[topic], stamp, bytes(found[0])
