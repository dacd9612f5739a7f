"""The shape every recording takes when read raw: connections, raw messages, blocks.

:class:`Source` is the base of the storage readers (``rosbag2``, ``rosbag1``);
:func:`zros.bag.read.source.open_source` picks one for a path.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.errors import BagError, Unsupported
from zros.bag.read.damage import Damage
from zros.closing import Closing
from zros.version import counted

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt


@dataclass(frozen=True)
class Connection:
    """One topic with one type in a recording.

    ``type_name`` is normalised to ``pkg/msg/Type`` (legacy ``pkg/Type`` names are expanded);
    ``definition`` is the embedded definition text in ``definition_format`` (``ros2msg``,
    ``ros2idl``, or ``''`` when the recording has none); ``qos`` is the offered QoS profiles as
    rosbag2 writes them in ``metadata.yaml`` (version 8), or ``''``; ``caller_id`` is the node
    that published (a ROS 1 connection header's ``callerid``; ``''`` where none is recorded).
    """

    id: int
    topic: str
    type_name: str
    definition: str
    definition_format: str
    serialization: str
    count: int
    qos: str
    caller_id: str = ''


@dataclass(frozen=True)
class RawMessage:
    """One recorded message: its connection, receive time (ns) and CDR bytes (header included)."""

    connection: Connection
    timestamp: int
    data: bytes | memoryview


@dataclass
class Block:
    """Messages of one connection read in bulk: receive times, file-order keys, CDR bytes."""

    connection: Connection
    times: npt.NDArray[np.int64]  #: receive times
    keys: npt.NDArray[np.int64]  #: ascending in file order
    data: Sequence[bytes]  #: (a Payloads where the storage gives whole chunks)


def normalise_type_name(name: str) -> str:
    """``pkg/Type`` -> ``pkg/msg/Type``; other names unchanged."""
    parts = name.split('/')
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    return name


class Source(Closing):
    """An open recording: its connections, time range and raw messages (a context manager).

    ``start_ns`` and ``end_ns`` are the first and last receive times (both 0 without messages).
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.connections: list[Connection] = []
        self.start_ns = 0
        self.end_ns = 0
        self.message_count = 0
        self.files: list[Path] = []
        self.storage_id = ''
        self.ros_distro: str | None = None
        self.compression_format = ''
        self.compression_mode = ''
        self._custom_data: dict[str, str] | None = None  #: read on first use (custom_data)
        self._closers: list[Callable[[], None]] = []
        self._closed = False
        #: what damage cost (``strict``: raise instead); :func:`open_source` sets the mode
        self.damage = Damage()

    def open(self) -> None:
        """Read the recording's connections and time range (:func:`open_source` calls it)."""
        raise NotImplementedError

    @property
    def custom_data(self) -> dict[str, str]:
        """rosbag2's ``custom_data`` (key -> text) where the recording has it; read on first
        use, so opening a recording costs nothing for it."""
        if self._custom_data is None:
            self._custom_data = self._read_custom_data()
        return self._custom_data

    def _read_custom_data(self) -> dict[str, str]:
        """The ``custom_data`` :meth:`open` did not read already (none by default)."""
        return {}

    @property
    def size_bytes(self) -> int:
        """Total size of the recording's files."""
        return sum(file.stat().st_size for file in self.files if file.exists())

    @property
    def duration_ns(self) -> int:
        """Time from the first to the last message."""
        return self.end_ns - self.start_ns

    def messages(
        self,
        connections: Iterable[Connection] | None = None,
        start: int | None = None,
        end: int | None = None,
    ) -> Iterator[RawMessage]:
        """Messages of ``connections`` (default all) with ``start <= timestamp < end``, in time
        order, read as the iteration goes."""
        if self._closed:
            raise BagError(self.path, 'the bag is closed')
        chosen = self.connections if connections is None else list(connections)
        known = {c.id for c in self.connections}
        for connection in chosen:
            if connection.id not in known or connection not in self.connections:
                raise ValueError(f'{connection.topic!r} is not a connection of {self.path}')
        ids = {c.id for c in chosen}
        if not ids:
            return iter(())
        return self._guarded(self._messages(ids, start, end))

    def _guarded(self, messages: Iterator[RawMessage]) -> Iterator[RawMessage]:
        try:
            yield from messages
        except BagError:
            raise
        except Exception as exc:  # the storage libraries raise what they like on a damaged file
            raise BagError(self.path, f'cannot read messages: {describe_error(exc)}') from exc

    def _messages(self, ids: set[int], start: int | None, end: int | None) -> Iterator[RawMessage]:
        raise NotImplementedError

    def locate(self, message: RawMessage) -> tuple[Path, int | None, int | None]:
        """Where a message lies, for a report of damage: (file, byte offset, row)."""
        return self.path, None, None

    def blocks(
        self, connections: Iterable[Connection], start: int | None = None, end: int | None = None
    ) -> Iterator[list[Block]]:
        """Messages in bulk, chunk by chunk, for column extraction (not in time order: each
        block's ``keys`` give the file order). Raises :class:`Unsupported` (possibly after some
        blocks) where the storage has no index for it: read :meth:`messages` instead."""
        raise Unsupported(f'{self.storage_id} storage')

    def close(self) -> None:
        """Release the files (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for closer in reversed(self._closers):
            with contextlib.suppress(Exception):  # closing must never mask the real error
                closer()

    def __repr__(self) -> str:
        return (
            f'<{type(self).__name__} {self.path} {self.storage_id}: '
            f'{counted(len(self.connections), "connection")}, '
            f'{counted(self.message_count, "message")}>'
        )


def describe_error(exc: BaseException) -> str:
    """The text of an error a storage reader raised, for a BagError."""
    text = str(exc).strip() or type(exc).__name__
    text = re.sub(r"\((['\"])(.*?)\1,\)", r'\2', text)  # rosbags puts a bare args tuple in some
    if isinstance(exc, MemoryError):
        text = 'a record claims more memory than available (corrupt file?)'
    return text
