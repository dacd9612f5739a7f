"""Raw messages of a recording, in time order, with nothing decoded.

:func:`open_source` opens a ROS 2 bag folder (``metadata.yaml`` with ``.db3`` or ``.mcap``
files, split or not), a bare ``.mcap`` or ``.db3`` file, or a ROS 1 ``.bag`` file. The storage
formats are read by ``rosbags``; this module gives them one shape: :class:`Connection` per
topic and type, :class:`RawMessage` per message, CDR bytes throughout.

ROS 1 messages are converted to CDR as ``rosbags-convert`` converts them: ``std_msgs/Header``
loses its ``seq``, so a ROS 1 message has the layout of its ROS 2 namesake. Their connections
carry ROS 2 ``.msg`` text generated from the ROS 1 connection headers.
"""

from __future__ import annotations

import contextlib
import heapq
import importlib
import itertools
import logging
import re
import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from zros.bag.errors import BagError
from zros.bag.mcap_bulk import Unsupported

if TYPE_CHECKING:
    from typing_extensions import Self

#: MessageDefinitionFormat names of rosbags -> the encodings of MCAP schemas and rosbag2
_log = logging.getLogger('zros.bag')
_SQL_BATCH = 16384
_FORMATS = {'MSG': 'ros2msg', 'IDL': 'ros2idl', 'NONE': ''}


@dataclass(frozen=True)
class Connection:
    """One topic with one type in a recording.

    ``type_name`` is normalised to ``pkg/msg/Type`` (legacy ``pkg/Type`` names are expanded);
    ``definition`` is the embedded definition text in ``definition_format`` (``ros2msg``,
    ``ros2idl``, or ``''`` when the recording has none); ``qos`` is the offered QoS profiles as
    rosbag2 writes them in ``metadata.yaml`` (version 8), or ``''``.
    """

    id: int
    topic: str
    type_name: str
    definition: str
    definition_format: str
    serialization: str
    count: int
    qos: str


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
    times: Any  #: int64 numpy array
    keys: Any  #: int64 numpy array, ascending in file order
    data: list[bytes]


@dataclass
class _Stream:
    """One storage file's reader and how its connections map to the source's."""

    reader: Any
    mapping: dict[int, Connection] = field(default_factory=dict)


def normalise_type_name(name: str) -> str:
    """``pkg/Type`` -> ``pkg/msg/Type``; other names unchanged."""
    parts = name.split('/')
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    return name


class Source:
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
        self._closers: list[Callable[[], None]] = []
        self._closed = False

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
        except Exception as exc:
            raise BagError(self.path, f'cannot read messages: {_describe(exc)}') from exc

    def _messages(self, ids: set[int], start: int | None, end: int | None) -> Iterator[RawMessage]:
        raise NotImplementedError

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

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return (
            f'<{type(self).__name__} {self.path} {self.storage_id}: '
            f'{len(self.connections)} connections, {self.message_count} messages>'
        )


def _describe(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    if isinstance(exc, MemoryError):
        text = 'a record claims more memory than available (corrupt file?)'
    return text


def _format_name(msgdef: Any) -> str:
    return _FORMATS.get(msgdef.format.name, '')


def _qos_text(ext: Any) -> str:
    from rosbags.rosbag2.metadata import dump_qos_v8

    profiles = getattr(ext, 'offered_qos_profiles', None)
    return str(dump_qos_v8(profiles)) if profiles else ''


# --- ROS 2 ----------------------------------------------------------------------------------


class _Rosbag2Source(Source):
    """A bag folder, or one bare ``.mcap`` / ``.db3`` file, through rosbags' storage readers."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self._streams: list[_Stream] = []
        self._decompress: Callable[[bytes], bytes] | None = None

    def open(self) -> None:
        from rosbags.rosbag2 import Reader

        folder = self.path.is_dir()
        if folder and not (self.path / 'metadata.yaml').is_file():
            self._open_files(storage_files(self.path), 'it has no metadata.yaml')
            return
        reader = Reader(self.path)
        try:
            reader.open()
        except Exception:
            files = self._listed_files() if folder else [self.path]
            if not files or not all(f.suffix == '.mcap' and _mcap_file(f) for f in files):
                raise
            self._open_files(files, 'its files do not open as complete MCAP files')
            return
        self._closers.append(reader.close)
        storage: Any = reader.storage
        folder = self.path.is_dir()
        storages = list(storage.storages) if folder else [storage]
        self._streams = [_Stream(s) for s in storages]
        meta = storage.metadata
        self.ros_distro = meta.ros_distro or None
        self.compression_format = meta.compression_format or ''
        self.compression_mode = meta.compression_mode or ''
        if self.compression_mode == 'message':
            zstd = importlib.import_module(
                'compression.zstd' if sys.version_info >= (3, 14) else 'backports.zstd'
            )
            self._decompress = zstd.decompress
        if folder:
            self.files = [self.path / 'metadata.yaml']
            self.files += [s.path for s in storage.storages]
            if self.compression_mode == 'file':
                self.files = [self.path / 'metadata.yaml', *self._compressed_files()]
        else:
            self.files = [self.path]
        self.storage_id = 'mcap' if type(storages[0]).__name__ == 'McapReader' else 'sqlite3'
        self._build_connections(list(storage.connections) if folder else [])

    def _listed_files(self) -> list[Path]:
        try:
            return self._compressed_files()
        except Exception:
            return []

    def _open_files(self, paths: list[Path], reason: str) -> None:
        """Open storage files one by one, reading MCAP files that were never finished (no
        summary or end: a recorder killed mid-file) up to their last complete record."""
        from rosbags.rosbag2.storage_mcap import McapReader
        from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader

        from zros.bag.mcap_recover import RecoveredMcap

        if not paths:
            raise BagError(self.path, f'not a ROS 2 bag folder: {reason} and no .mcap or .db3 file')
        notes = []
        for path in paths:
            storage: Any = Sqlite3Reader(path) if path.suffix == '.db3' else McapReader(path)
            try:
                storage.open()
            except Exception:
                if path.suffix != '.mcap' or not _mcap_file(path):
                    raise
                storage = RecoveredMcap(path)
                storage.open()
                if not storage.connections:
                    if len(paths) == 1:
                        raise BagError(path, f'no complete record: {storage.stopped_at}') from None
                    notes.append(f'{path.name}: no complete record, skipped')
                    continue
                notes.append(
                    f'{path.name}: {storage.metadata.message_count} messages up to its last '
                    f'complete record ({storage.stopped_at or "no summary"})'
                )
            self._closers.append(storage.close)
            self._streams.append(_Stream(storage))
        metadata = self.path / 'metadata.yaml'
        self.files = ([metadata] if metadata.is_file() else []) + paths
        self.storage_id = 'sqlite3' if paths[0].suffix == '.db3' else 'mcap'
        self._build_connections([])
        if notes or self.path.is_dir():
            _log.warning(
                '%s: %s: read file by file%s', self.path, reason, ''.join('; ' + n for n in notes)
            )

    def _compressed_files(self) -> list[Path]:
        from ruamel.yaml import YAML

        text = (self.path / 'metadata.yaml').read_text(encoding='utf-8')
        info = YAML(typ='safe').load(text)['rosbag2_bagfile_information']
        return [self.path / Path(name).name for name in info['relative_file_paths']]

    def _build_connections(self, declared: list[Any]) -> None:
        # counts and times come from the storage files: metadata.yaml can be wrong about them
        items: dict[tuple[str, str], Any] = {}
        counts: dict[tuple[str, str], int] = {}
        for item in declared:
            items.setdefault((item.topic, item.msgtype), item)
            counts[(item.topic, item.msgtype)] = 0
        for stream in self._streams:
            for item in stream.reader.connections:
                key = (item.topic, item.msgtype)
                items.setdefault(key, item)
                counts[key] = counts.get(key, 0) + item.msgcount
        by_key: dict[tuple[str, str], Connection] = {}
        for index, (key, item) in enumerate(items.items(), 1):
            by_key[key] = self._connection(index, item, counts[key])
        self.connections = list(by_key.values())
        for stream in self._streams:
            for item in stream.reader.connections:
                stream.mapping[item.id] = by_key[(item.topic, item.msgtype)]
        metas = [s.reader.metadata for s in self._streams if s.reader.metadata.message_count]
        self.message_count = sum(meta.message_count for meta in metas)
        if metas:
            self.start_ns = min(meta.start_time for meta in metas)
            self.end_ns = max(meta.end_time for meta in metas) - 1

    def _connection(self, index: int, item: Any, count: int) -> Connection:
        definition, form = self._definition(item)
        return Connection(
            id=index,
            topic=item.topic,
            type_name=normalise_type_name(item.msgtype),
            definition=definition,
            definition_format=form,
            serialization=item.ext.serialization_format,
            count=count,
            qos=_qos_text(item.ext),
        )

    def _definition(self, item: Any) -> tuple[str, str]:
        if _format_name(item.msgdef):
            return item.msgdef.data, _format_name(item.msgdef)
        for stream in self._streams:
            for other in stream.reader.connections:
                if other.msgtype == item.msgtype and _format_name(other.msgdef):
                    return other.msgdef.data, _format_name(other.msgdef)
        # rosbag2's db3 stores a service event's definition under the service's name
        if item.msgtype.endswith('_Event'):
            service = item.msgtype[: -len('_Event')]
            for stream in self._streams:
                for entry in getattr(stream.reader, 'msgtypes', []):
                    if entry.get('name') == service and entry.get('msgdef'):
                        return entry['msgdef'], entry.get('encoding') or 'ros2msg'
        return '', ''

    def _messages(self, ids: set[int], start: int | None, end: int | None) -> Iterator[RawMessage]:
        iterators = []
        for stream in self._streams:
            wanted = [c for c in stream.reader.connections if stream.mapping[c.id].id in ids]
            if wanted:
                iterators.append(self._stream(stream, wanted, start, end))
        if len(iterators) == 1:
            return iterators[0]
        return heapq.merge(*iterators, key=_timestamp)

    def _stream(
        self, stream: _Stream, wanted: list[Any], start: int | None, end: int | None
    ) -> Iterator[RawMessage]:
        mapping = stream.mapping
        decompress = self._decompress
        for item, timestamp, data in stream.reader.messages(wanted, start, end):
            raw = data if decompress is None else decompress(data)
            yield RawMessage(mapping[item.id], timestamp, raw)

    def blocks(
        self, connections: Iterable[Connection], start: int | None = None, end: int | None = None
    ) -> Iterator[list[Block]]:
        from zros.bag.mcap_bulk import read_blocks

        if self._decompress is not None:
            raise Unsupported('compressed messages are read one by one')
        ids = {c.id for c in connections}
        base = 0
        for stream in self._streams:
            channels = {cid for cid, c in stream.mapping.items() if c.id in ids}
            if not channels:
                continue
            if self.storage_id == 'sqlite3':
                yield from _sqlite_blocks(stream, channels, start, end)
                continue
            for found in read_blocks(Path(stream.reader.path), channels, start, end):
                blocks = [
                    Block(stream.mapping[b.channel], b.times, base + b.order, b.data)
                    for b in found
                    if b.order is not None and len(b.times)
                ]
                base += sum(len(b.times) for b in found)
                if blocks:
                    yield blocks


def _sqlite_blocks(
    stream: _Stream, topics: set[int], start: int | None, end: int | None
) -> Iterator[list[Block]]:
    """Rows of the messages table in batches, unordered (the row id is the file order)."""
    import numpy as np

    query = 'SELECT topic_id, timestamp, id, data FROM messages WHERE topic_id IN ({})'.format(
        ','.join('?' * len(topics))
    )
    args: list[int] = sorted(topics)
    if start is not None:
        query += ' AND timestamp >= ?'
        args.append(start)
    if end is not None:
        query += ' AND timestamp < ?'
        args.append(end)
    cursor = stream.reader.dbconn.execute(query, args)
    while rows := list(itertools.islice(cursor, _SQL_BATCH)):
        grouped: dict[int, tuple[list[int], list[int], list[bytes]]] = {}
        for topic, stamp, key, data in rows:
            entry = grouped.get(topic)
            if entry is None:
                entry = grouped[topic] = ([], [], [])
            entry[0].append(stamp)
            entry[1].append(key)
            entry[2].append(data)
        yield [
            Block(stream.mapping[topic], np.asarray(t, np.int64), np.asarray(k, np.int64), d)
            for topic, (t, k, d) in grouped.items()
        ]


def _timestamp(message: RawMessage) -> int:
    return message.timestamp


def _mcap_file(path: Path) -> bool:
    from zros.bag.mcap_recover import is_mcap

    try:
        return path.is_file() and is_mcap(path)
    except OSError:
        return False


def storage_files(folder: Path) -> list[Path]:
    """The ``.mcap`` or ``.db3`` files of a folder, in split order (``name_0``, ``name_1``...)."""

    def order(path: Path) -> tuple[str, int, str]:
        match = re.search(r'_(\d+)$', path.stem)
        stem = path.stem[: match.start()] if match else path.stem
        return (stem, int(match.group(1)) if match else -1, path.name)

    found = sorted([*folder.glob('*.mcap'), *folder.glob('*.db3')], key=order)
    kinds = {path.suffix for path in found}
    return [path for path in found if path.suffix == '.mcap'] if len(kinds) > 1 else found


# --- ROS 1 ----------------------------------------------------------------------------------


class _Rosbag1Source(Source):
    """A ROS 1 bag; messages are converted to CDR of their ROS 2 layout."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self._reader: Any = None
        self._store: Any = None
        self._native: dict[int, Any] = {}

    def open(self) -> None:
        from rosbags.rosbag1 import Reader
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        reader = Reader(self.path)
        reader.open()
        self._reader = reader
        self._closers.append(reader.close)
        self.files = [self.path]
        self.storage_id = 'rosbag1'
        self.ros_distro = None
        types: dict[str, Any] = {}
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
        convert = self._store.ros1_to_cdr
        for item, timestamp, data in self._reader.messages(wanted, start, end):
            yield RawMessage(by_native[item.id], timestamp, convert(data, item.msgtype))


def _ros1_qos(ext: Any) -> str:
    """A latched ROS 1 topic is offered as transient local, as rosbags-convert writes it."""
    if not getattr(ext, 'latching', 0):
        return ''
    from rosbags.convert.converter import LATCH
    from rosbags.rosbag2.metadata import dump_qos_v8

    return str(dump_qos_v8(LATCH))


# --- opening --------------------------------------------------------------------------------


def open_source(path: str | Path) -> Source:
    """Open a recording for raw reading; raises :class:`BagError` naming the file and cause."""
    location = Path(path).expanduser()
    if not location.exists():
        raise BagError(location, 'no such file or folder')
    source: _Rosbag1Source | _Rosbag2Source
    if location.is_dir():
        source = _Rosbag2Source(location)
    elif location.suffix == '.bag':
        source = _Rosbag1Source(location)
    elif location.suffix in ('.mcap', '.db3'):
        source = _Rosbag2Source(location)
    elif location.name == 'metadata.yaml':
        return open_source(location.parent)
    else:
        raise BagError(
            location,
            'not a recording zros reads (expected a bag folder, .mcap, .db3 or ROS 1 .bag)',
        )
    try:
        source.open()
    except BagError:
        source.close()
        raise
    except Exception as exc:
        source.close()
        raise BagError(location, f'cannot open the recording: {_describe(exc)}') from exc
    return source


__all__ = ['Connection', 'RawMessage', 'Source', 'normalise_type_name', 'open_source']
