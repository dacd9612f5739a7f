"""A rosbag2 bag folder being written: ``<name>_0.mcap``, ``<name>_1.mcap``... and
``metadata.yaml``, split by size or duration as ``ros2 bag record`` splits.

Messages are raw CDR bytes; nothing is decoded. Not thread-safe: one thread writes (the
recorder's writer thread, or a script making a bag).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.errors import BagWriteError
from zros.bag.read.rosbag2_yaml import (
    FileEntry,
    TopicEntry,
    bag_metadata,
    dump,
    qos_profiles_text,
    write_metadata_yaml,
)
from zros.bag.write.mcap_writer import DEFAULT_CHUNK_SIZE, McapFile, compression_type
from zros.cdr.hashing import type_hash
from zros.cdr.render import render_bundle
from zros.closing import Closing
from zros.errors import ZrosError
from zros.qos import QoS
from zros.version import __version__

if TYPE_CHECKING:
    from zros.cdr import TypeRegistry

_log = logging.getLogger('zros.bag')
_NS = 1_000_000_000


@dataclass
class BagTopic:
    """A topic of a bag being written: what its channel and metadata entry say."""

    name: str
    type_name: str
    definition: str = ''  #: ``ros2msg`` text with dependencies; empty when the type is unknown
    type_hash: str = ''
    qos: list[QoS] = field(default_factory=list)  #: the offered profiles of its publishers
    message_count: int = 0

    @property
    def encoding(self) -> str:
        """The schema encoding: ``ros2msg``, or empty (no schema) for an unknown type."""
        return 'ros2msg' if self.definition else ''

    @classmethod
    def from_registry(
        cls,
        registry: TypeRegistry,
        name: str,
        type_name: str,
        qos: Sequence[QoS] = (),
    ) -> BagTopic:
        """A topic whose definition and hash come from ``registry`` (left empty if unknown)."""
        try:
            definition = render_bundle(registry, type_name)
            digest = type_hash(registry, type_name)
        except ZrosError as exc:
            _log.warning('recording %s without a definition: %s', name, exc)
            definition = digest = ''
        return cls(name, type_name, definition, digest, list(qos))


class BagWriter(Closing):
    """Writes a bag folder. ``split_size`` is in bytes, ``split_duration`` in seconds;
    ``compression`` is ``'zstd'``, ``'lz4'`` or None (chunk compression, inside each file)."""

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        compression: str | None = 'zstd',
        split_size: int | None = None,
        split_duration: float | None = None,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        ros_distro: str = '',
        custom_data: Mapping[str, str] | None = None,
    ) -> None:
        compression_type(compression)  # refuse a bad name before creating anything
        if split_size is not None and split_size <= 0:
            raise BagWriteError(f'the maximum file size must be positive, got {split_size}')
        if split_duration is not None and not split_duration > 0:
            raise BagWriteError(f'the maximum file duration must be positive, got {split_duration}')
        self.path = Path(path)
        if self.path.exists():
            raise BagWriteError(f'the output folder {self.path} already exists: choose another')
        try:
            self.path.mkdir(parents=True)
        except OSError as exc:
            raise BagWriteError(f'cannot create the output folder {self.path}: {exc}') from None
        self.name = self.path.name
        self._compression = compression
        self._chunk_size = chunk_size
        self._split_size = split_size
        self._split_ns = None if split_duration is None else round(split_duration * _NS)
        self._distro = ros_distro
        #: rosbag2's ``custom_data``: written into ``metadata.yaml`` and each file's end
        self.custom_data: dict[str, str] = dict(custom_data or {})
        self.topics: list[BagTopic] = []
        self._done: list[FileEntry] = []  #: closed files
        self._done_size = 0
        self._channels: dict[int, int] = {}  #: topic index -> channel id in the open file
        self._file: McapFile | None = None
        self.message_count = 0
        self.closed = False
        self._open_next()
        self.write_metadata()

    # --- files -------------------------------------------------------------------------------

    def _open_next(self) -> None:
        name = f'{self.name}_{len(self._done)}.mcap'
        self._file = McapFile(
            self.path / name, self._compression, self._chunk_size, f'zros {__version__}'
        )
        self._channels = {}
        for index in range(len(self.topics)):
            self._add_channel(index)

    def _add_channel(self, index: int) -> None:
        assert self._file is not None
        topic = self.topics[index]
        self._channels[index] = self._file.add_channel(
            topic=topic.name,
            type_name=topic.type_name,
            definition=topic.definition,
            encoding=topic.encoding,
            offered_qos_profiles=qos_profiles_text(topic.qos),
            type_hash=topic.type_hash,
        )

    def _entry(self, file: McapFile) -> FileEntry:
        stats = file.stats
        return FileEntry(
            os.path.basename(file.path), stats.start_ns, stats.duration_ns, stats.message_count
        )

    def _close_file(self) -> None:
        file = self._file
        if file is None:
            return
        self._file = None
        entry = self._entry(file)
        files = [*self._done, entry]
        file.close(dump(self._metadata(files)))
        self._done.append(entry)
        self._done_size += os.path.getsize(file.path)

    def _split(self) -> None:
        self._close_file()
        self._open_next()
        self.write_metadata()

    def _metadata(self, files: Sequence[FileEntry]) -> Mapping[str, object]:
        topics = [
            TopicEntry(t.name, t.type_name, qos_profiles_text(t.qos), t.type_hash, t.message_count)
            for t in self.topics
        ]
        return bag_metadata(files, topics, self._distro, self.custom_data)

    # --- writing -----------------------------------------------------------------------------

    def add_topic(self, topic: BagTopic) -> int:
        """Add a topic (a channel in this file and every later one); returns its index."""
        self._check_open()
        if any(t.name == topic.name for t in self.topics):
            raise BagWriteError(f'the bag already has a topic {topic.name}')
        self.topics.append(topic)
        index = len(self.topics) - 1
        self._add_channel(index)
        self.write_metadata()
        return index

    def write(
        self, topic: int, log_time: int, data: bytes, publish_time: int | None = None
    ) -> None:
        """Add one message of topic index ``topic``; times in nanoseconds."""
        file = self._file
        if file is None:
            raise BagWriteError(f'the bag {self.path} is closed')
        if file.stats.message_count and self._full(file, log_time):
            self._split()
            file = self._file
            assert file is not None
        file.write(
            self._channels[topic],
            log_time,
            log_time if publish_time is None else publish_time,
            data,
        )
        self.topics[topic].message_count += 1
        self.message_count += 1

    def _full(self, file: McapFile, log_time: int) -> bool:
        """Whether the open file reached the split size or duration."""
        if self._split_ns is not None and log_time - file.stats.start_ns >= self._split_ns:
            return True
        if self._split_size is None or file.size < self._split_size:
            return False
        file.flush()  # the open chunk counts uncompressed until written: measure it for real
        return file.size >= self._split_size

    def flush(self) -> None:
        """Close the open chunk so everything written so far is on disk (survives SIGKILL)."""
        if self._file is not None:
            self._file.flush()

    def write_metadata(self) -> None:
        """Write ``metadata.yaml`` for what is written so far, the open file included (its
        counts are those of :attr:`files` as they stand). A killed recording then has a
        metadata file that names its files and topics; ``zros bag reindex`` makes it exact."""
        files = list(self._done)
        if self._file is not None:
            files.append(self._entry(self._file))
        write_metadata_yaml(self.path, self._metadata(files))

    @property
    def size(self) -> int:
        """Bytes written so far (the open chunk counted uncompressed)."""
        return self._done_size + (self._file.size if self._file is not None else 0)

    @property
    def files(self) -> list[Path]:
        """The storage files, in order (the open one last)."""
        paths = [self.path / entry.path for entry in self._done]
        if self._file is not None:
            paths.append(Path(self._file.path))
        return paths

    def _check_open(self) -> None:
        if self.closed:
            raise BagWriteError(f'the bag {self.path} is closed')

    def close(self) -> None:
        """Finish the open file and write ``metadata.yaml``; safe to call twice."""
        if self.closed:
            return
        self.closed = True
        self._close_file()
        write_metadata_yaml(self.path, self._metadata(self._done))
