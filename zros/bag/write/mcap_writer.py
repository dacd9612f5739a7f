"""One ``.mcap`` file of a rosbag2 bag, written as rosbag2_storage_mcap writes it.

Profile ``ros2``; one schema per type (``ros2msg`` definition text, or empty for an unknown
type); one channel per topic with encoding ``cdr`` and the metadata ``offered_qos_profiles`` and
``topic_type_hash``; messages in chunks (zstd, lz4 or none); a ``rosbag2`` metadata record with
the bag's serialized metadata before the summary.

Chunks are closed here, not by the mcap library: when the open chunk reaches ``chunk_size``
bytes, or when :meth:`McapFile.flush` is called. Each closed chunk goes to the operating system
at once, so a process killed with SIGKILL leaves a file readable up to its last closed chunk.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from mcap.writer import CompressionType

#: bytes a Message record adds to its data (opcode, length, channel, sequence, two times)
MESSAGE_OVERHEAD = 1 + 8 + 2 + 4 + 8 + 8
#: chunk size of rosbag2_storage_mcap (the mcap C++ library's default)
DEFAULT_CHUNK_SIZE = 768 * 1024
COMPRESSIONS = ('zstd', 'lz4', 'none')


class McapWriter(Protocol):
    """What zros calls of mcap's ``Writer`` (typed here: ``flush`` and ``finish`` are not)."""

    def start(self, profile: str, library: str) -> None: ...

    def register_schema(self, name: str, encoding: str, data: bytes) -> int: ...

    def register_channel(
        self, topic: str, message_encoding: str, schema_id: int, metadata: dict[str, str]
    ) -> int: ...

    def add_message(
        self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int = 0
    ) -> None: ...

    def add_metadata(self, name: str, data: dict[str, str]) -> None: ...

    def add_attachment(
        self, create_time: int, log_time: int, name: str, media_type: str, data: bytes
    ) -> None: ...

    def flush(self) -> None: ...

    def finish(self) -> None: ...


def compression_type(name: str | None) -> CompressionType:
    """The MCAP compression for ``'zstd'``, ``'lz4'`` or ``'none'``/None."""
    from mcap.writer import CompressionType  # noqa: PLC0415 (lazy: mcap, import time)

    choice = (name or 'none').lower()
    if choice not in COMPRESSIONS:
        raise ValueError(f'unknown compression {name!r}; choose one of {", ".join(COMPRESSIONS)}')
    return {
        'zstd': CompressionType.ZSTD,
        'lz4': CompressionType.LZ4,
        'none': CompressionType.NONE,
    }[choice]


@dataclass
class FileStats:
    """What one file holds: messages, their time span, and counts per channel."""

    message_count: int = 0
    start_ns: int = 0  #: first log time (0 while empty)
    end_ns: int = 0  #: last log time
    per_channel: dict[int, int] = field(default_factory=dict)

    @property
    def duration_ns(self) -> int:
        return self.end_ns - self.start_ns if self.message_count else 0


class McapFile:
    """Writes one MCAP file; not thread-safe (one writer thread owns it)."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        compression: str | None = 'zstd',
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        library: str = 'zros',
    ) -> None:
        from mcap.writer import Writer  # noqa: PLC0415 (lazy: mcap, import time)

        if chunk_size < 1:
            raise ValueError(f'chunk_size must be positive, got {chunk_size}')
        kind = compression_type(compression)
        self.path = os.fspath(path)
        self._stream = open(self.path, 'xb')  # noqa: SIM115 (closed in close())
        # the library never closes a chunk by itself: this class decides (size or flush)
        self._writer: McapWriter = Writer(
            self._stream, chunk_size=2**62, compression=kind, enable_crcs=True
        )
        self._writer.start(profile='ros2', library=library)
        self._stream.flush()  # a file killed before its first chunk still opens as MCAP
        self._chunk_size = chunk_size
        self._pending = 0  #: bytes in the open chunk
        self._schemas: dict[str, int] = {}
        self.stats = FileStats()
        self.closed = False

    def add_channel(
        self,
        *,
        topic: str,
        type_name: str,
        definition: str,
        encoding: str,
        offered_qos_profiles: str,
        type_hash: str,
    ) -> int:
        """Register a topic (its schema once per type); returns the channel id."""
        schema_id = self._schemas.get(type_name)
        if schema_id is None:
            data = definition.encode() if encoding else b''
            schema_id = self._writer.register_schema(type_name, encoding, data)
            self._schemas[type_name] = schema_id
            self._pending += len(type_name) + len(data) + 20
        metadata = {'offered_qos_profiles': offered_qos_profiles, 'topic_type_hash': type_hash}
        channel_id: int = self._writer.register_channel(topic, 'cdr', schema_id, metadata)
        self._pending += len(topic) + len(offered_qos_profiles) + len(type_hash) + 60
        return channel_id

    def write(self, channel_id: int, log_time: int, publish_time: int, data: bytes) -> None:
        """Add one message; closes the chunk once it holds ``chunk_size`` bytes."""
        self._writer.add_message(channel_id, log_time, data, publish_time)
        stats = self.stats
        if not stats.message_count:
            stats.start_ns = stats.end_ns = log_time
        elif log_time > stats.end_ns:
            stats.end_ns = log_time
        elif log_time < stats.start_ns:
            stats.start_ns = log_time
        stats.message_count += 1
        stats.per_channel[channel_id] = stats.per_channel.get(channel_id, 0) + 1
        self._pending += MESSAGE_OVERHEAD + len(data)
        if self._pending >= self._chunk_size:
            self.flush()

    @property
    def pending(self) -> int:
        """Bytes waiting in the open chunk."""
        return self._pending

    @property
    def size(self) -> int:
        """Bytes on disk plus the open chunk (uncompressed): what the file will about hold."""
        return self._stream.tell() + self._pending

    def flush(self) -> None:
        """Close the open chunk (if it holds messages) and hand it to the operating system."""
        if self._pending and self.stats.message_count:
            self._writer.flush()  # the chunk, then the stream (no fsync)
            self._pending = 0

    def close(self, serialized_metadata: str | None = None) -> None:
        """Write the ``rosbag2`` metadata record, the summary and the footer; close the file."""
        if self.closed:
            return
        self.closed = True
        try:
            self.flush()
            if serialized_metadata is not None:
                self._writer.add_metadata('rosbag2', {'serialized_metadata': serialized_metadata})
            self._writer.finish()
        finally:
            self._stream.close()
