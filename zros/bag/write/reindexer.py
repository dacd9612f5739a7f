"""``zros bag reindex``: make a bag a killed recorder left readable by every reader again.

A recorder killed with SIGKILL (or a power loss) leaves its last MCAP file without summary,
indexes and footer, and the bag possibly without an up-to-date ``metadata.yaml``: rosbags
cannot open such a bag and the mcap library's default reader refuses the file. As
``ros2 bag reindex``, :func:`reindex` rebuilds ``metadata.yaml`` from the files; since Python
readers need a finished MCAP file (rosbag2's C++ reader scans an unfinished one itself), each
unfinished file is first rewritten into a finished one holding its complete records: messages
up to the last complete chunk (and the whole ones of a last chunk cut short), then chunk and
message indexes, statistics, the summary and the footer.

Files already finished are left untouched. An unfinished file is rewritten into a hidden
temporary file beside it (``.<name>.reindex``), synced to disk, then renamed over the original
in one step: if anything fails before the rename (disk full, a crash), the original is still
there as it was, and running :func:`reindex` again starts over. The original is kept beside it
as ``NAME.orig.EXT`` (as ROS 1's ``rosbag reindex`` keeps ``.orig.bag``; ``backup=False`` does
not), and a file of which no message would be kept while it held some is refused: left as it
is, reported ``'refused'``. What the rewrite drops is what
no reader can read: the bytes after the last complete record, but for the whole messages of a
last chunk the file's end cuts short (:mod:`zros.bag.read.mcap_cut`).
"""

from __future__ import annotations

import copy
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.errors import BagError
from zros.bag.read.mcap_recover import LinearScan, is_mcap
from zros.bag.write.mcap_writer import DEFAULT_CHUNK_SIZE, McapWriter, compression_type
from zros.bag.write.replace import backup_of, lost_words, replacing, temporary_of
from zros.version import counted

if TYPE_CHECKING:
    from mcap.records import Channel, Message, Schema

    from zros.bag.boundary import YamlValue
from zros.bag.read.rosbag2 import storage_files
from zros.bag.read.rosbag2_yaml import (
    FileEntry,
    TopicEntry,
    bag_metadata,
    distro_and_custom,
    dump,
    write_metadata_yaml,
)


@dataclass(frozen=True)
class FileReport:
    """What :func:`reindex` did with one storage file.

    ``action`` is ``'complete'`` (already finished and intact: untouched), ``'rewritten'``
    (finished from its complete records; ``dropped_bytes`` were past the last one, ``reason``
    says why the scan stopped; damaged chunks are left out, ``lost_messages`` counts their
    messages, -1 when a chunk's count is unknown; the original kept as ``backup``, '' when
    not kept), ``'refused'`` (no message of it reads though it holds data: left as it is,
    not listed in the metadata) or ``'skipped'`` (not even an MCAP header: left as it is, not
    listed in the metadata).
    """

    name: str
    action: str
    message_count: int
    dropped_bytes: int = 0
    reason: str = ''
    lost_messages: int = 0
    damaged: tuple[int, ...] = ()  #: byte offsets of the damaged chunks left out
    backup: str = ''  #: the name the original is kept under beside it ('' when not kept)

    def __str__(self) -> str:
        if self.action == 'complete':
            return f'{self.name}: complete, {counted(self.message_count, "message")}'
        if self.action == 'skipped':
            return f'{self.name}: skipped, no complete MCAP record ({self.reason})'
        if self.action == 'refused':
            return (
                f'{self.name}: refused, left as it is: no message of it reads, so a rewrite '
                f'would hold none ({self.reason})'
            )
        kept = f'\n  the original is kept as {self.backup}' if self.backup else ''
        return self._rewritten() + kept

    def _rewritten(self) -> str:
        if self.damaged:
            lost = lost_words(self.lost_messages)
            at = ', '.join(map(str, self.damaged))
            return (
                f'{self.name}: rewritten, {counted(self.message_count, "message")}; could not '
                f'keep {lost} (damaged or cut short at byte {at})'
            )
        messages = counted(self.message_count, 'message')
        if self.dropped_bytes:  # the reason says what of them was read (a last chunk cut short)
            return (
                f'{self.name}: rewritten, {messages} up to its last whole message (the '
                f'{self.dropped_bytes} bytes after its last complete chunk: {self.reason})'
            )
        return (
            f'{self.name}: rewritten, {messages} up to its last complete chunk (it had no '
            'summary and footer)'
        )


@dataclass(frozen=True)
class ReindexReport:
    """The outcome of :func:`reindex`: one :class:`FileReport` per storage file, and the
    ``metadata.yaml`` written (None for a bare ``.mcap`` file)."""

    path: Path
    files: list[FileReport]
    metadata: Path | None
    topic_count: int

    @property
    def message_count(self) -> int:
        """Messages the bag holds now."""
        return sum(f.message_count for f in self.files)

    @property
    def refused(self) -> bool:
        """Whether a file was refused (left as it is: nothing of it would be kept)."""
        return any(f.action == 'refused' for f in self.files)

    def __str__(self) -> str:
        lines = [str(f) for f in self.files]
        if self.metadata is not None:
            used = sum(1 for f in self.files if f.action not in ('skipped', 'refused'))
            lines.append(
                f'Wrote {self.metadata}: {counted(self.message_count, "message")} on '
                f'{counted(self.topic_count, "topic")} in {counted(used, "file")}'
            )
        return '\n'.join(lines)


@dataclass
class _Channel:
    """One channel of a file: what the bag's topic list needs."""

    topic: str
    type_name: str
    metadata: dict[str, str]
    count: int = 0


@dataclass
class _FileSummary:
    """What one finished file holds."""

    entry: FileEntry
    channels: list[_Channel] = field(default_factory=list)


@dataclass
class _Bag:
    """The bag as known from the files read so far."""

    distro: str = ''
    custom: dict[str, str] = field(default_factory=dict)
    files: list[FileEntry] = field(default_factory=list)
    topics: dict[tuple[str, str], _Channel] = field(default_factory=dict)

    def add(self, summary: _FileSummary) -> None:
        self.files.append(summary.entry)
        for channel in summary.channels:
            key = (channel.topic, channel.type_name)
            known = self.topics.get(key)
            if known is None:
                self.topics[key] = _Channel(*key, channel.metadata, channel.count)
            else:
                known.count += channel.count

    def metadata(self) -> dict[str, YamlValue]:
        """The ``rosbag2_bagfile_information`` of the files added so far."""
        topics = [
            TopicEntry(
                c.topic,
                c.type_name,
                c.metadata.get('offered_qos_profiles', ''),
                c.metadata.get('topic_type_hash', ''),
                c.count,
            )
            for c in self.topics.values()
        ]
        return bag_metadata(self.files, topics, self.distro, self.custom)

    def serialized_with(self, summary: _FileSummary) -> str:
        """The metadata a file's ``rosbag2`` record holds: the files up to it, as rosbag2's
        MCAP storage writes it when closing the file."""
        bag = _Bag(self.distro, self.custom, list(self.files), copy.deepcopy(self.topics))
        bag.add(summary)
        return dump(bag.metadata())


def reindex(path: str | os.PathLike[str], *, backup: bool = True) -> ReindexReport:
    """Finish every unfinished MCAP file of a bag and rewrite its ``metadata.yaml`` from the
    files, as ``ros2 bag reindex`` does; returns what was done.

    ``path`` is a bag folder, one ``.mcap`` file (which gets no ``metadata.yaml``) or a ROS 1
    ``.bag``. Each file rewritten is kept as ``NAME.orig.EXT`` beside it unless ``backup`` is
    false; a file no message of which reads though it holds data is left as it is (its report
    says ``'refused'``, :attr:`ReindexReport.refused`). Raises :class:`BagError` for a path
    that is no bag, or when writing fails (the file being rewritten then keeps its original
    content). Not for a bag a recorder is still writing: its open file would be replaced under
    it.
    """
    location = Path(path).expanduser()
    if not location.exists():
        raise BagError(location, 'no such file or folder')
    if location.is_file():
        if location.suffix == '.bag':
            from zros.bag.write.reindex_ros1 import reindex_ros1  # noqa: PLC0415 (ROS 1 only)

            done = reindex_ros1(location, backup_of(location) if backup else None)
            report = FileReport(
                location.name,
                done.action,
                done.message_count,
                0,
                done.reason,
                done.lost_messages,
                done.damaged,
                done.backup,
            )
            return ReindexReport(location, [report], None, 0)
        if location.suffix != '.mcap':
            raise BagError(
                location, 'reindex reads MCAP and ROS 1 bags (a folder, a .mcap or .bag file)'
            )
        return ReindexReport(location, [_reindex_file(location, _Bag(), backup)], None, 0)
    files = storage_files(location)
    if not files:
        raise BagError(location, 'not a bag folder: no .mcap file in it')
    if any(file.suffix != '.mcap' for file in files):
        raise BagError(location, 'reindex reads MCAP bags; this folder holds .db3 files')
    bag = _Bag(*_previous_metadata(location / 'metadata.yaml'))
    reports = [_reindex_file(file, bag, backup) for file in files]
    metadata = write_metadata_yaml(location, bag.metadata())
    return ReindexReport(location, reports, metadata, len(bag.topics))


def _reindex_file(file: Path, bag: _Bag, backup: bool) -> FileReport:
    """Finish one file if needed and add it to ``bag``."""
    stale = temporary_of(file)
    stale.unlink(missing_ok=True)  # left by a reindex that was itself interrupted
    if not _has_magic(file):
        return FileReport(file.name, 'skipped', 0, reason='no MCAP magic')
    summary = _finished_summary(file)
    if summary is not None and _intact(file):
        report = FileReport(file.name, 'complete', summary.entry.message_count)
    else:
        finished = summary is not None
        kept = backup_of(file) if backup else None
        try:
            summary, scan = _rewrite(file, bag, finished, kept)
        except _Refused as refused:
            return FileReport(file.name, 'refused', 0, reason=str(refused))
        if summary is None:
            return FileReport(file.name, 'skipped', 0, reason=scan.stopped_at)
        dropped = _dropped(scan, finished)
        count = summary.entry.message_count
        report = FileReport(
            file.name,
            'rewritten',
            count,
            dropped,
            '' if finished else scan.stopped_at,
            _lost(scan),
            tuple(offset for offset, _, _ in scan.skipped),
            kept.name if kept is not None else '',
        )
    bag.add(summary)
    return report


class _Refused(Exception):
    """A rewrite that would keep no message of a file holding some: the original stays."""


def _dropped(scan: LinearScan, finished: bool) -> int:
    """The bytes after the last complete record (a finished file's summary is past its last
    chunk: not dropped, rewritten)."""
    return 0 if finished else max(0, scan.size - scan.end)


def _lost(scan: LinearScan) -> int:
    """The messages of the damaged chunks (-1 when a chunk's count is unknown)."""
    losses = [sum(lost.values()) if lost and -1 not in lost else -1 for _, lost, _ in scan.skipped]
    return -1 if -1 in losses else sum(losses)


def _intact(file: Path) -> bool:
    """Whether every chunk of a finished file reads: decompresses, its CRC matches, its
    messages match their index (a pass over the file: reindex is the repair, it takes the
    time)."""
    scan = LinearScan(file)
    for _ in scan.records():
        pass
    return not scan.skipped


def _has_magic(file: Path) -> bool:
    try:
        return is_mcap(file)
    except OSError:
        return False


def _finished_summary(file: Path) -> _FileSummary | None:
    """The summary of a finished file (None when it has no readable footer and summary)."""
    from mcap.exceptions import McapError  # noqa: PLC0415 (lazy: mcap, import time)
    from mcap.reader import make_reader  # noqa: PLC0415 (lazy: mcap, import time)

    with file.open('rb') as stream:
        try:
            summary = make_reader(stream).get_summary()
        except (McapError, ValueError, struct.error):
            return None
        if summary is None or summary.statistics is None:
            return _counted(file)
        stats = summary.statistics
        channels = [
            _Channel(
                channel.topic,
                _schema_name(summary.schemas, channel.schema_id),
                dict(channel.metadata),
                stats.channel_message_counts.get(channel.id, 0),
            )
            for channel in summary.channels.values()
        ]
        return _FileSummary(
            _entry(file, stats.message_count, stats.message_start_time, stats.message_end_time),
            channels,
        )


def _counted(file: Path) -> _FileSummary | None:
    """A finished file without statistics: counted by reading it through."""
    from mcap.records import Channel, Message, Schema  # noqa: PLC0415 (lazy: mcap, import time)

    scan = LinearScan(file)
    stats = _Stats()
    for record in scan.records():
        if isinstance(record, Schema | Channel | Message):
            stats.add(record)
    return None if scan.stopped_at else stats.summary(file)


def _schema_name(schemas: dict[int, Schema], schema_id: int) -> str:
    schema = schemas.get(schema_id)
    return schema.name if schema is not None else ''


def _entry(file: Path, count: int, start: int, end: int) -> FileEntry:
    return FileEntry(file.name, start if count else 0, end - start if count else 0, count)


class _Stats:
    """Counts and times of the records read so far."""

    def __init__(self) -> None:
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, _Channel] = {}
        self.count = 0
        self.start = 0
        self.end = 0

    def add(self, record: Schema | Channel | Message) -> None:
        from mcap.records import Channel, Schema  # noqa: PLC0415 (lazy: mcap, import time)

        if isinstance(record, Schema):
            self.schemas[record.id] = record
        elif isinstance(record, Channel):
            self.channels.setdefault(
                record.id,
                _Channel(
                    record.topic,
                    _schema_name(self.schemas, record.schema_id),
                    dict(record.metadata),
                ),
            )
        else:
            channel = self.channels.get(record.channel_id)
            if channel is not None:
                channel.count += 1
            stamp = record.log_time
            if not self.count:
                self.start = self.end = stamp
            self.start = min(self.start, stamp)
            self.end = max(self.end, stamp)
            self.count += 1

    def summary(self, file: Path) -> _FileSummary:
        return _FileSummary(
            _entry(file, self.count, self.start, self.end), list(self.channels.values())
        )


def _rewrite(
    file: Path, bag: _Bag, finished: bool, backup: Path | None
) -> tuple[_FileSummary | None, LinearScan]:
    """Rewrite an unfinished file from its complete records, into a temporary file renamed
    over the original once complete and on disk (the original kept as ``backup``). (None,
    scan) when there is no header; raises :class:`_Refused` when no message would be kept of
    a file holding some data."""
    from mcap.records import Attachment, Channel, Header, Message, Metadata, Schema  # noqa: PLC0415 (lazy: mcap, import time)
    from mcap.writer import Writer  # noqa: PLC0415 (lazy: mcap, import time)

    scan = LinearScan(file)
    records = scan.records()
    header = next(records, None)
    if not isinstance(header, Header):
        return None, scan
    stats = _Stats()
    schemas: dict[int, int] = {0: 0}
    channels: dict[int, int] = {}
    with replacing(file, backup) as temporary, temporary.open('xb') as stream:
        writer: McapWriter | None = None
        for record in records:
            if writer is None:
                kind = compression_type(scan.compression or 'none')
                writer = Writer(stream, chunk_size=DEFAULT_CHUNK_SIZE, compression=kind)
                writer.start(profile=header.profile, library=header.library)
            if isinstance(record, Schema) and record.id not in schemas:
                schemas[record.id] = writer.register_schema(
                    record.name, record.encoding, record.data
                )
            elif isinstance(record, Channel) and record.id not in channels:
                channels[record.id] = writer.register_channel(
                    record.topic,
                    record.message_encoding,
                    schemas.get(record.schema_id, 0),
                    dict(record.metadata),
                )
            elif isinstance(record, Message) and record.channel_id in channels:
                writer.add_message(
                    channels[record.channel_id],
                    record.log_time,
                    record.data,
                    record.publish_time,
                    record.sequence,
                )
            elif isinstance(record, Metadata) and record.name != 'rosbag2':
                writer.add_metadata(record.name, dict(record.metadata))
            elif isinstance(record, Attachment):
                writer.add_attachment(
                    record.create_time,
                    record.log_time,
                    record.name,
                    record.media_type,
                    record.data,
                )
            else:
                continue
            if isinstance(record, Schema | Channel | Message):
                stats.add(record)
        dropped = _dropped(scan, finished)
        if not stats.count and (scan.skipped or dropped):
            said = []
            if scan.skipped:
                at = ', '.join(str(offset) for offset, _, _ in scan.skipped)
                said.append(f'{lost_words(_lost(scan))} damaged at byte {at}')
            if dropped:
                said.append(f'{dropped} bytes after its last complete record: {scan.stopped_at}')
            raise _Refused('; '.join(said))
        if writer is None:
            writer = Writer(stream, compression=compression_type('none'))
            writer.start(profile=header.profile, library=header.library)
        summary = stats.summary(file)
        writer.add_metadata('rosbag2', {'serialized_metadata': bag.serialized_with(summary)})
        writer.finish()
    return summary, scan


def _previous_metadata(path: Path) -> tuple[str, dict[str, str]]:
    """The ROS distro and custom data of an existing ``metadata.yaml`` (what the files do not
    say); empty when there is none or it does not parse."""
    try:
        return distro_and_custom(path.read_text(encoding='utf-8'))
    except (OSError, UnicodeDecodeError):
        return '', {}
