"""ROS 2 recordings: a bag folder (split or not), or one bare ``.mcap`` or ``.db3`` file.

The storage formats are read by rosbags' storage readers; MCAP files that were never finished
are read by :mod:`zros.bag.read.mcap_recover` up to their last complete record.
"""

from __future__ import annotations

import heapq
import importlib
import itertools
import logging
import os
import re
import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from zros.bag.errors import BagError, Unsupported
from zros.bag.read.damage import Skipped
from zros.bag.read.db3_recover import RecoveredDb3, is_sqlite
from zros.bag.read.mcap_chunks import Damaged, ordered_messages, read_blocks
from zros.bag.read.mcap_recover import RecoveredMcap, is_mcap
from zros.bag.read.recovered import SqlStorageReader, StorageReader, path_of
from zros.bag.read.rosbag2_yaml import distro_and_custom
from zros.bag.read.source_base import Block, Connection, RawMessage, Source, normalise_type_name

if TYPE_CHECKING:
    from rosbags.interfaces import Connection as NativeConnection
    from rosbags.interfaces import MessageDefinition

_log = logging.getLogger('zros.bag')
_SQL_BATCH = 16384
#: MessageDefinitionFormat names of rosbags -> the encodings of MCAP schemas and rosbag2
_FORMATS = {'MSG': 'ros2msg', 'IDL': 'ros2idl', 'NONE': ''}


@dataclass
class _Stream:
    """One storage file's reader and how its connections map to the source's."""

    reader: StorageReader  #: a rosbags storage reader, a RecoveredMcap or a RecoveredDb3
    mapping: dict[int, Connection] = field(default_factory=dict)


def _format_name(msgdef: MessageDefinition) -> str:
    return _FORMATS.get(msgdef.format.name, '')


def _qos_text(ext: object) -> str:
    from rosbags.rosbag2.metadata import dump_qos_v8  # noqa: PLC0415 (lazy: rosbags, import time)

    profiles = getattr(ext, 'offered_qos_profiles', None)
    return str(dump_qos_v8(profiles)) if profiles else ''


class Rosbag2Source(Source):
    """A bag folder, or one bare ``.mcap`` / ``.db3`` file, through rosbags' storage readers."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        self._streams: list[_Stream] = []
        self._decompress: Callable[[bytes], bytes] | None = None

    def open(self) -> None:
        from rosbags.rosbag2 import Reader  # noqa: PLC0415 (lazy: rosbags, import time)
        from rosbags.rosbag2.reader import DirectoryReader  # noqa: PLC0415 (lazy: as above)

        folder = self.path.is_dir()
        if folder and not (self.path / 'metadata.yaml').is_file():
            self._open_files(storage_files(self.path), 'it has no metadata.yaml')
            return
        reader = Reader(self.path)
        try:
            reader.open()
        except Exception:  # whatever rosbags raised: raised again unless the MCAP files recover
            files = self._listed_files() if folder else [self.path]
            if not files or not all(_recoverable(f) for f in files):
                raise
            _log.debug('rosbags cannot open %s: recovering its files', self.path, exc_info=True)
            self._open_files(files, 'its files do not open as complete MCAP or db3 files')
            return
        self._closers.append(reader.close)
        storage = reader.storage  # a folder's reader, or one file's
        folder = self.path.is_dir()
        parts = storage.storages if isinstance(storage, DirectoryReader) else []
        storages: list[StorageReader] = list(parts) if folder else [storage]
        self._streams = [_Stream(s) for s in storages]
        meta = storage.metadata
        self.ros_distro = meta.ros_distro or None
        self.compression_format = meta.compression_format or ''
        self.compression_mode = meta.compression_mode or ''
        custom = meta.custom
        if isinstance(custom, dict):  # anything else in a hand-edited metadata.yaml is ignored
            self._custom_data = {str(k): str(v) for k, v in custom.items()}
        if self.compression_mode == 'message':
            zstd = importlib.import_module(
                'compression.zstd' if sys.version_info >= (3, 14) else 'backports.zstd'
            )
            self._decompress = zstd.decompress
        if folder:
            self.files = [self.path / 'metadata.yaml']
            self.files += [path_of(s) for s in parts]
            if self.compression_mode == 'file':
                self.files = [self.path / 'metadata.yaml', *self._compressed_files()]
        else:
            self.files = [self.path]
        self.storage_id = 'mcap' if type(storages[0]).__name__ == 'McapReader' else 'sqlite3'
        self._build_connections(list(storage.connections) if folder else [])

    def _read_custom_data(self) -> dict[str, str]:
        # rosbags reads no metadata of a lone MCAP file: its own, asked for (a second look at
        # its summary, which opening the bag need not pay)
        if not self.path.is_dir() and is_mcap(self.path):
            return _embedded_custom_data(self.path)
        return {}

    def _listed_files(self) -> list[Path]:
        try:
            return self._compressed_files()
        except Exception as exc:  # a metadata.yaml rosbags refused: read what the folder holds
            _log.debug('%s: metadata.yaml lists no files zros can use: %s', self.path, exc)
            return []

    def _open_files(self, paths: list[Path], reason: str) -> None:
        """Open storage files one by one, reading MCAP files that were never finished (no
        summary or end: a recorder killed mid-file) up to their last complete record."""
        from rosbags.rosbag2.storage_mcap import McapReader  # noqa: PLC0415 (lazy: rosbags, import time)
        from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader  # noqa: PLC0415 (lazy: rosbags, import time)

        if not paths:
            raise BagError(self.path, f'not a ROS 2 bag folder: {reason} and no .mcap or .db3 file')
        notes = []
        whole = 0  #: complete MCAP files rosbags refused
        for path in paths:
            storage: StorageReader = (
                Sqlite3Reader(path) if path.suffix == '.db3' else McapReader(path)
            )
            try:
                storage.open()
            except Exception as exc:  # whatever rosbags raised: raised again unless it recovers
                if not _recoverable(path):
                    raise
                _log.debug('rosbags cannot open %s: recovering it', path, exc_info=True)
                if path.suffix == '.db3':
                    storage = RecoveredDb3(path)
                    self._closers.append(storage.close)
                    storage.open()
                    notes.append(f'{path.name}: read row by row ({exc})')
                    self._streams.append(_Stream(storage))
                    continue
                recovered = RecoveredMcap(path)
                storage = recovered
                recovered.open()
                if not recovered.connections:
                    if len(paths) == 1:
                        raise BagError(
                            path, f'no complete record: {recovered.stopped_at}'
                        ) from None
                    notes.append(f'{path.name}: no complete record, skipped')
                    continue
                if not recovered.stopped_at and not recovered.skipped:
                    # whole (a schema encoding rosbags does not know): no damage to tell
                    _log.debug('%s reads whole record by record', path)
                    whole += 1
                    self._closers.append(storage.close)
                    self._streams.append(_Stream(storage))
                    continue
                count = recovered.metadata.message_count if recovered.metadata else 0
                notes.append(
                    f'{path.name}: {count} messages up to its last '
                    f'complete record ({recovered.stopped_at or "no summary"})'
                )
            self._closers.append(storage.close)
            self._streams.append(_Stream(storage))
        metadata = self.path / 'metadata.yaml'
        self.files = ([metadata] if metadata.is_file() else []) + paths
        self.storage_id = 'sqlite3' if paths[0].suffix == '.db3' else 'mcap'
        self._build_connections([])
        if notes or self.path.is_dir():  # how it is read, before what reading it lost
            # a folder of one complete file reads as that file: no warning on every open
            level = logging.WARNING if notes or len(paths) - whole > 1 else logging.DEBUG
            _log.log(
                level, '%s: %s: read file by file%s', self.path, reason,
                ''.join('; ' + n for n in notes),
            )  # fmt: skip
        for stream in self._streams:
            if isinstance(stream.reader, RecoveredMcap):
                report = self._damaged(stream.reader.path, stream.mapping)
                for offset, lost, why in stream.reader.skipped:
                    report(offset, lost or {-1: -1}, why)
            elif isinstance(stream.reader, RecoveredDb3):
                for first, count in _runs(stream.reader.lost_rows):
                    why = (
                        'the row does not read'
                        if count == 1
                        else f'rows {first} to {first + count - 1} do not read'
                    )
                    self.damage.report([Skipped(stream.reader.path, None, first, '', count, why)])

    def _compressed_files(self) -> list[Path]:
        from ruamel.yaml import YAML  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

        text = (self.path / 'metadata.yaml').read_text(encoding='utf-8')
        info = YAML(typ='safe').load(text)['rosbag2_bagfile_information']
        return [self.path / Path(name).name for name in info['relative_file_paths']]

    def _build_connections(self, declared: list[NativeConnection]) -> None:
        # counts and times come from the storage files: metadata.yaml can be wrong about them
        items: dict[tuple[str, str], NativeConnection] = {}
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
        metas = [m for s in self._streams if (m := s.reader.metadata) and m.message_count]
        self.message_count = sum(meta.message_count for meta in metas)
        if metas:
            self.start_ns = min(meta.start_time for meta in metas)
            self.end_ns = max(meta.end_time for meta in metas) - 1

    def _connection(self, index: int, item: NativeConnection, count: int) -> Connection:
        from rosbags.interfaces import ConnectionExtRosbag2  # noqa: PLC0415 (lazy: rosbags, import time)

        ext = item.ext
        assert isinstance(ext, ConnectionExtRosbag2)  # rosbag2 storages make no other
        definition, form = self._definition(item)
        return Connection(
            id=index,
            topic=item.topic,
            type_name=normalise_type_name(item.msgtype),
            definition=definition,
            definition_format=form,
            serialization=ext.serialization_format,
            count=count,
            qos=_qos_text(ext),
        )

    def _definition(self, item: NativeConnection) -> tuple[str, str]:
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
        # a schema encoding no ROS reader reads: said as it is (types.py says it is unread)
        unknown = getattr(item.owner, 'unknown_encodings', {}).get(item.id)
        return (item.msgdef.data, unknown) if unknown else ('', '')

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
        self, stream: _Stream, wanted: list[NativeConnection], start: int | None, end: int | None
    ) -> Iterator[RawMessage]:
        mapping = stream.mapping
        decompress = self._decompress
        skip: list[tuple[int, bytes]] = []
        if self.storage_id == 'mcap' and decompress is None:
            # whole chunks through their message indexes, without rosbags' step per record
            path = path_of(stream.reader)
            try:
                for connection, timestamp, data in ordered_messages(
                    path,
                    {item.id: mapping[item.id] for item in wanted},
                    start,
                    end,
                    self._damaged(path, mapping),
                ):
                    if skip and timestamp != start:
                        skip = []
                    start = timestamp
                    skip.append((connection.id, data))
                    yield RawMessage(connection, timestamp, data)
                return
            except Unsupported:
                pass  # rosbags reads it, from the last time given (those given are skipped)
        for item, timestamp, data in stream.reader.messages(wanted, start, end):
            if skip and timestamp == start and (mapping[item.id].id, bytes(data)) in skip:
                skip.remove((mapping[item.id].id, bytes(data)))
                continue
            raw = data if decompress is None else decompress(data)
            yield RawMessage(mapping[item.id], timestamp, raw)

    def locate(self, message: RawMessage) -> tuple[Path, int | None, int | None]:
        """A db3 message's file and row; the bag's path for others."""
        if self.storage_id == 'sqlite3' and self._decompress is None:
            for stream in self._streams:
                ids = [n for n, c in stream.mapping.items() if c == message.connection]
                if not ids:
                    continue
                database = cast(SqlStorageReader, stream.reader).dbconn  # storage_id says so
                query = (
                    'SELECT id FROM messages WHERE timestamp = ? AND data = ? AND topic_id IN '
                    f'({",".join("?" * len(ids))})'
                )
                try:
                    args = [message.timestamp, bytes(message.data), *ids]
                    found = database.execute(query, args).fetchone()
                except Exception:  # a damaged database: the row stays unnamed
                    continue
                if found:
                    return path_of(stream.reader), None, int(found[0])
        return self.path, None, None

    def _damaged(self, path: Path, mapping: dict[int, Connection]) -> Damaged:
        """Reports a chunk of ``path`` that cannot be read (channel ids as in ``mapping``)."""

        def report(offset: int, lost: dict[int, int], reason: str) -> None:
            self.damage.report(
                [
                    Skipped(path, offset, None, mapping[c].topic if c in mapping else '', n, reason)
                    for c, n in lost.items()
                ]
            )

        return report

    def blocks(
        self, connections: Iterable[Connection], start: int | None = None, end: int | None = None
    ) -> Iterator[list[Block]]:
        if self._decompress is not None:
            raise Unsupported('compressed messages are read one by one')
        ids = {c.id for c in connections}
        base = 0
        for stream in self._streams:
            channels = {cid: c for cid, c in stream.mapping.items() if c.id in ids}
            if not channels:
                continue
            if isinstance(stream.reader, RecoveredDb3):
                raise Unsupported('a damaged db3 is read row by row')
            if self.storage_id == 'sqlite3':
                yield from _sqlite_blocks(stream, set(channels), start, end)
                continue
            path = path_of(stream.reader)
            damaged = self._damaged(path, stream.mapping)
            for found in read_blocks(
                path, channels, start, end, mapped=mapping_chunks(), damaged=damaged
            ):
                blocks = [
                    Block(b.connection, b.times, base + b.keys, b.data)
                    for b in found
                    if len(b.times)
                ]
                base += sum(len(b.times) for b in found)
                if blocks:
                    yield blocks


def _sqlite_blocks(
    stream: _Stream, topics: set[int], start: int | None, end: int | None
) -> Iterator[list[Block]]:
    """Rows of the messages table in batches, unordered (the row id is the file order)."""
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
    cursor = cast(SqlStorageReader, stream.reader).dbconn.execute(query, args)
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


def mapping_chunks() -> bool:
    """Whether ``Bag.columns`` maps MCAP chunks (the default) rather than reading them into
    memory: ``ZROS_BAG_MMAP=0`` (or false/no/off) reads them, so a file cut short while it is
    read raises an error instead of ending the process with SIGBUS."""
    return os.environ.get('ZROS_BAG_MMAP', '').strip().lower() not in ('0', 'false', 'no', 'off')


def _timestamp(message: RawMessage) -> int:
    return message.timestamp


def _mcap_file(path: Path) -> bool:
    try:
        return path.is_file() and is_mcap(path)
    except OSError:
        return False


def _recoverable(path: Path) -> bool:
    """Whether a storage file rosbags cannot open is one zros reads around its damage."""
    try:
        if path.suffix == '.db3':
            return path.is_file() and is_sqlite(path)
        return path.suffix == '.mcap' and _mcap_file(path)
    except OSError:
        return False


def _runs(rows: list[int]) -> Iterator[tuple[int, int]]:
    """(first, count) of each run of consecutive ids in sorted ``rows``."""
    first = count = 0
    for row in rows:
        if count and row == first + count:
            count += 1
            continue
        if count:
            yield first, count
        first, count = row, 1
    if count:
        yield first, count


#: what ``reindex`` adds to a file's stem for the original it keeps (``bag_0.orig.mcap``)
BACKUP_MARK = '.orig'


def storage_files(folder: Path) -> list[Path]:
    """The ``.mcap`` or ``.db3`` files of a folder, in split order (``name_0``, ``name_1``...);
    not the originals ``reindex`` kept (``bag_0.orig.mcap``, ``bag_0.orig-2.mcap``)."""

    def order(path: Path) -> tuple[str, int, str]:
        match = re.search(r'_(\d+)$', path.stem)
        stem = path.stem[: match.start()] if match else path.stem
        return (stem, int(match.group(1)) if match else -1, path.name)

    found = sorted([*folder.glob('*.mcap'), *folder.glob('*.db3')], key=order)
    found = [
        path for path in found if not re.search(rf'{re.escape(BACKUP_MARK)}(-\d+)?$', path.stem)
    ]
    kinds = {path.suffix for path in found}
    return [path for path in found if path.suffix == '.mcap'] if len(kinds) > 1 else found


def _embedded_custom_data(path: Path) -> dict[str, str]:
    """The ``custom_data`` of the rosbag2 metadata an MCAP file holds (rosbag2 and zros write
    it before the summary); empty without a summary, so a damaged file is never scanned."""
    from mcap.reader import make_reader  # noqa: PLC0415 (lazy: mcap, import time)

    try:
        with path.open('rb') as stream:
            reader = make_reader(stream)
            if reader.get_summary() is None:
                return {}
            for record in reader.iter_metadata():
                if record.name == 'rosbag2':
                    text = record.metadata.get('serialized_metadata', '')
                    return distro_and_custom(text)[1]
    except Exception as exc:  # the mcap library raises what it likes on a damaged file
        _log.debug('%s: its rosbag2 metadata does not read: %s', path, exc)
    return {}
