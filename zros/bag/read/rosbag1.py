"""ROS 1 recordings (``.bag``): messages converted to CDR of their ROS 2 layout.

They are converted as ``rosbags-convert`` converts them: ``std_msgs/Header`` loses its ``seq``,
so a ROS 1 message has the layout of its ROS 2 namesake. Their connections carry ROS 2 ``.msg``
text generated from the ROS 1 connection headers.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.read.source_base import Connection, RawMessage, Source, normalise_type_name

if TYPE_CHECKING:
    from rosbags.interfaces import Connection as NativeConnection
    from rosbags.interfaces.typing import Typesdict
    from rosbags.rosbag1 import Reader
    from rosbags.typesys.store import Typestore


class Rosbag1Source(Source):
    """A ROS 1 bag; messages are converted to CDR of their ROS 2 layout."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self._reader: Reader | None = None
        self._store: Typestore | None = None
        self._native: dict[int, NativeConnection] = {}

    def open(self) -> None:
        from rosbags.rosbag1 import Reader  # noqa: PLC0415 (lazy: rosbags, import time)
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore  # noqa: PLC0415 (lazy: rosbags, import time)

        reader = Reader(self.path)
        reader.open()
        self._reader = reader
        self._closers.append(reader.close)
        self.files = [self.path]
        self.storage_id = 'rosbag1'
        self.ros_distro = None
        types: Typesdict = {}
        for item in reader.connections:
            types.update(get_types_from_msg(item.msgdef.data, item.msgtype))
        # the ROS 2 header: rosbags' ROS 1 to CDR conversion drops seq
        header = 'std_msgs/msg/Header'
        types[header] = get_typestore(Stores.ROS2_JAZZY).fielddefs[header]
        store = get_typestore(Stores.EMPTY)
        store.register(types)
        self._store = store
        for item in reader.connections:
            definition = store.generate_msgdef(item.msgtype, ros_version=2)[0]
            connection = Connection(
                id=len(self.connections) + 1,
                topic=item.topic,
                type_name=normalise_type_name(item.msgtype),
                definition=definition,
                definition_format='ros2msg',
                serialization='cdr',
                count=item.msgcount,
                qos=_ros1_qos(item.ext),
            )
            self.connections.append(connection)
            self._native[connection.id] = item
        self.message_count = sum(c.count for c in self.connections)
        if self.message_count:
            self.start_ns = reader.start_time
            self.end_ns = reader.end_time - 1

    def _messages(self, ids: set[int], start: int | None, end: int | None) -> Iterator[RawMessage]:
        by_native = {self._native[c.id].id: c for c in self.connections if c.id in ids}
        wanted = [self._native[c.id] for c in self.connections if c.id in ids]
        assert self._reader is not None and self._store is not None, 'the source is not open'
        convert = self._store.ros1_to_cdr
        for item, timestamp, data in self._reader.messages(wanted, start, end):
            yield RawMessage(by_native[item.id], timestamp, convert(data, item.msgtype))


def _ros1_qos(ext: object) -> str:
    """A latched ROS 1 topic is offered as transient local, as rosbags-convert writes it."""
    if not getattr(ext, 'latching', 0):
        return ''
    from rosbags.convert.converter import LATCH  # noqa: PLC0415 (lazy: rosbags, import time)
    from rosbags.rosbag2.metadata import dump_qos_v8  # noqa: PLC0415 (lazy: rosbags, import time)

    return str(dump_qos_v8(LATCH))
