"""ROS 1 recordings (``.bag``): messages converted to CDR of their ROS 2 layout.

They are converted as ``rosbags-convert`` converts them: ``std_msgs/Header`` loses its ``seq``,
so a ROS 1 message has the layout of its ROS 2 namesake. Their connections carry ROS 2 ``.msg``
text generated from the ROS 1 connection headers.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.errors import BagError
from zros.bag.read.damage import Skipped
from zros.bag.read.rosbag1_scan import ScannedBag1, indexed_messages, why
from zros.bag.read.source_base import (
    Connection,
    RawMessage,
    Source,
    describe_error,
    normalise_type_name,
)

_log = logging.getLogger('zros.bag')

if TYPE_CHECKING:
    from rosbags.interfaces import Connection as NativeConnection
    from rosbags.interfaces.typing import Typesdict
    from rosbags.typesys.store import Typestore

    from zros.bag.read.rosbag1_index import IndexedBag1


class Rosbag1Source(Source):
    """A ROS 1 bag; messages are converted to CDR of their ROS 2 layout."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self._reader: IndexedBag1 | ScannedBag1 | None = None
        self._broken: dict[int, str] = {}  #: native connection id -> why it cannot be read
        self._store: Typestore | None = None
        self._native: dict[int, NativeConnection] = {}

    def open(self) -> None:
        from zros.bag.read.rosbag1_index import IndexedBag1  # noqa: PLC0415 (lazy: rosbags, import time)

        reader: IndexedBag1 | ScannedBag1 = IndexedBag1(self.path)
        try:
            reader.open()
        except Exception as exc:  # a bag cut short or with a damaged index: read its records
            _log.debug('rosbags cannot open %s: scanning it', self.path, exc_info=True)
            reader = ScannedBag1(self.path)
            reader.open()
            if not reader.connections:
                raise BagError(
                    self.path, f'{describe_error(exc)}; and no chunk could be read'
                ) from None
            _log.warning(
                '%s: %s: read record by record%s',
                self.path,
                describe_error(exc).rstrip('.'),
                f', up to {reader.stopped_at}' if reader.stopped_at else '',
            )
        self._reader = reader
        self._closers.append(reader.close)
        self.files = [self.path]
        self.storage_id = 'rosbag1'
        self.ros_distro = None
        store, broken = ros1_typestore(reader.connections)
        self._store = store
        for item in reader.connections:
            try:
                definition = store.generate_msgdef(item.msgtype, ros_version=2)[0]
            except Exception as exc:  # a type its definition misses: only its topic fails
                broken.setdefault(item.id, f'cannot read the definition of {item.msgtype}: {exc}')
                definition = ''
            connection = Connection(
                id=len(self.connections) + 1,
                topic=item.topic,
                type_name=normalise_type_name(item.msgtype),
                definition=definition,
                definition_format='ros2msg',
                serialization='cdr',
                count=item.msgcount,
                qos=_ros1_qos(item.ext),
                caller_id=getattr(item.ext, 'callerid', None) or '',
            )
            self.connections.append(connection)
            self._native[connection.id] = item
        self.message_count = sum(c.count for c in self.connections)
        if self.message_count:
            self.start_ns = reader.start_time
            self.end_ns = reader.end_time - 1
        self._broken = broken
        for cid, reason in broken.items():  # where: the first chunk of its messages
            lost = {cid: getattr(self._by_native(cid), 'count', -1)}
            self._damaged(reader.first_chunk.get(cid, 0), lost, reason)
        if isinstance(reader, ScannedBag1):
            for offset, lost, reason in reader.losses:
                self._damaged(offset, lost, reason)

    def _by_native(self, native: int) -> Connection | None:
        return next((c for c in self.connections if self._native[c.id].id == native), None)

    def _topic(self, native: int) -> str:
        connection = self._by_native(native)
        return '' if connection is None else connection.topic

    def _damaged(self, offset: int, lost: dict[int, int], reason: str) -> None:
        """Report a damaged unit (lost: messages per native connection id; -1: unknown)."""
        self.damage.report(
            [
                Skipped(
                    self.path,
                    offset or None,
                    None,
                    self._topic(cid),
                    count,
                    reason,
                )
                for cid, count in lost.items()
            ]
        )

    def _messages(self, ids: set[int], start: int | None, end: int | None) -> Iterator[RawMessage]:
        by_native = {self._native[c.id].id: c for c in self.connections if c.id in ids}
        wanted = [
            self._native[c.id]
            for c in self.connections
            if c.id in ids and self._native[c.id].id not in self._broken
        ]
        assert self._reader is not None and self._store is not None, 'the source is not open'
        convert = self._store.ros1_to_cdr
        reader = self._reader
        if isinstance(reader, ScannedBag1):
            found = reader.messages(wanted, start, end)
        else:
            found = indexed_messages(reader, wanted, start, end, self._damaged)
        for item, timestamp, data in found:
            try:
                converted = convert(data, item.msgtype)
            except Exception as exc:  # flipped bytes in the message: anything from rosbags
                reason = f'the message at {timestamp} does not convert: {why(exc)}'
                self._damaged(reader.position, {item.id: 1}, reason)
                continue
            yield RawMessage(by_native[item.id], timestamp, converted)


def ros1_typestore(connections: list[NativeConnection]) -> tuple[Typestore, dict[int, str]]:
    """The types of ROS 1 connections, to convert their messages to CDR (with ROS 2's header:
    rosbags' conversion drops ``seq``), and why those whose definitions do not parse fail (by
    connection id)."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: PLC0415 (lazy: rosbags, import time)

    types: Typesdict = {}
    broken: dict[int, str] = {}
    for item in connections:
        try:
            types.update(get_types_from_msg(item.msgdef.data, item.msgtype))
        except Exception as exc:  # a damaged connection record: only its topic fails
            broken[item.id] = f'cannot read the definition of {item.msgtype}: {why(exc)}'
    header = 'std_msgs/msg/Header'
    types[header] = get_typestore(Stores.ROS2_JAZZY).fielddefs[header]
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return store, broken


def _ros1_qos(ext: object) -> str:
    """A latched ROS 1 topic is offered as transient local, as rosbags-convert writes it."""
    if not getattr(ext, 'latching', 0):
        return ''
    from rosbags.convert.converter import LATCH  # noqa: PLC0415 (lazy: rosbags, import time)
    from rosbags.rosbag2.metadata import dump_qos_v8  # noqa: PLC0415 (lazy: rosbags, import time)

    return str(dump_qos_v8(LATCH))
