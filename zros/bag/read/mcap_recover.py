"""An MCAP file that never got its summary and end (a recorder killed mid-file), read up to its
last complete record, and the whole messages of a last chunk that the file's end cuts short.

The mcap library's stream reader scans the file linearly (chunk CRCs checked) and stops at the
first record that is cut short or corrupt; everything before it is read. The class has the
interface of rosbags' storage readers, so :mod:`zros.bag.read.rosbag2` treats it like one.
"""

from __future__ import annotations

import mmap
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from zros.bag.read.mcap_cut import (
    CHUNK_HEAD,
    CHUNK_OPCODE,
    COMPRESSIONS,
    RECORD,
    cut_chunk,
    intact_start,
    read_cut,
    read_part,
)
from zros.bag.read.merge import Scanned, merged
from zros.bag.read.recovered import Recovered, within

if TYPE_CHECKING:
    from mcap.records import Channel, McapRecord, Schema
    from rosbags.interfaces import Connection
    from rosbags.rosbag2.metadata import ReaderMetadata

MAGIC = b'\x89MCAP0\r\n'
_FORMATS = {'ros2msg': 'MSG', 'ros2idl': 'IDL', 'omgidl': 'IDL'}
#: the most messages outside chunks read again as one unit (they are held until merged)
_RUN = 1000


def is_mcap(path: Path) -> bool:
    """Whether the file starts with the MCAP magic."""
    with path.open('rb') as stream:
        return stream.read(len(MAGIC)) == MAGIC


class LinearScan:
    """One pass over the complete records of an MCAP file, from its start.

    Chunks are read whole and their CRCs checked before any record inside them is yielded, so a
    corrupt chunk yields only what its message index confirms; the last chunk, when the file's
    end cuts it short, yields the whole records of its part present
    (:mod:`zros.bag.read.mcap_cut`). A whole chunk that does not decompress or whose CRC fails
    yields the messages before the damage that its message index records after it confirm
    (none without them), is listed in ``skipped`` (with the messages per channel it lost) and
    the scan goes on after it; after a
    record that does not parse, it goes on at the next record laid out as a chunk (``skipped``
    counts what lay between as unknown, channel and count -1). After the iteration,
    ``stopped_at`` says why it stopped before the end ('' when it reached the footer), ``end``
    is the byte offset just past the last complete record, and ``compression`` is the first
    chunk's ('' without chunks). While a record is yielded, ``unit`` is where the unit it came
    from lies (start and end byte: a chunk with its message indexes, or the record itself
    outside chunks) and ``in_chunk`` whether that unit is a chunk: :meth:`records` from ``unit``
    reads it again.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.stopped_at = ''
        self.end = 0
        self.size = 0  #: the file's size when the scan began
        self.compression = ''
        #: chunks skipped as damaged: (offset, messages lost per channel id, why)
        self.skipped: list[tuple[int, dict[int, int], str]] = []
        self.unit = (0, 0)
        self.in_chunk = False
        self._chunked = False
        self._damage = ''  #: why the chunk held failed its CRC or decompression (else '')

    def records(self, start: int = 0, stop: int | None = None) -> Iterator[McapRecord]:
        """Header, schemas, channels, messages, metadata, attachments... in file order; from
        the record at byte ``start`` (default the file's start) to the last one before byte
        ``stop`` (default the end)."""
        from mcap.exceptions import EndOfFile  # noqa: PLC0415 (lazy: mcap, import time)
        from mcap.records import Chunk, MessageIndex  # noqa: PLC0415 (lazy: mcap, import time)
        from mcap.stream_reader import StreamReader, breakup_chunk  # noqa: PLC0415 (lazy: mcap, import time)

        self.size = size = self.path.stat().st_size
        with self.path.open('rb') as stream:
            stream.seek(start)
            reader = StreamReader(
                stream,
                skip_magic=start > 0,
                emit_chunks=True,
                validate_crcs=True,
                record_size_limit=size,
            )
            records = reader.records
            held: list[McapRecord] = []  # the last chunk's records, until its indexes are read
            held_at = 0
            indexed: dict[int, list[int]] = {}  # its message index: channel -> log times
            while True:
                at = max(stream.tell(), len(MAGIC))  # the first read takes the magic too
                if stop is not None and at >= stop:
                    yield from self._held(held, held_at, at, indexed)
                    return
                try:
                    record = next(records)
                except StopIteration:
                    yield from self._held(held, held_at, at, indexed)
                    return
                except Exception as exc:  # a record cut short or corrupt
                    yield from self._held(held, held_at, at, indexed)
                    held, indexed = [], {}
                    following = None if isinstance(exc, EndOfFile) else next_chunk(stream, at + 1)
                    if following is None:  # the end of what can be read
                        yield from self._cut(stream, at, size, exc)
                        return
                    why = _why(stream, at, size, exc, cut=False)
                    self.skipped.append((at, {-1: -1}, f'{why}; read on at byte {following}'))
                    stream.seek(following)
                    records = StreamReader(
                        stream,
                        skip_magic=True,
                        emit_chunks=True,
                        validate_crcs=True,
                        record_size_limit=size,
                    ).records
                    continue
                self.end = stream.tell()
                if isinstance(record, MessageIndex):
                    if held or self._damage:  # log times in the chunk's order
                        entries = sorted(record.records, key=lambda entry: entry[1])
                        indexed[record.channel_id] = [time for time, _ in entries]
                    continue
                yield from self._held(held, held_at, at, indexed)
                held, indexed = [], {}
                if not isinstance(record, Chunk):
                    self.unit, self.in_chunk = (at, self.end), False
                    yield record
                    continue
                if not self._chunked:
                    self._chunked = True
                    self.compression = record.compression
                held_at = at
                try:
                    held = breakup_chunk(record, validate_crc=True)
                except Exception as exc:  # whole but damaged: its start, the scan goes on
                    part, held, _ = intact_start(at, record)
                    self._damage = f'{str(exc) or type(exc).__name__}; {read_part(part)}'

    def _cut(self, stream: BinaryIO, at: int, size: int, exc: Exception) -> Iterator[McapRecord]:
        """The whole records of a chunk at byte ``at`` that the file's end cuts short (none
        when the record there is not such a chunk); ``stopped_at`` says what was read."""
        chunk = cut_chunk(stream, at, size)
        if chunk is None:
            self.stopped_at = _why(stream, at, size, exc, cut=True)
            return
        if not self._chunked and chunk.data_at is not None:
            self._chunked = True
            self.compression = chunk.compression
        self.unit, self.in_chunk = (at, size), True
        yield from read_cut(stream, chunk)
        self.stopped_at = chunk.describe()

    def _held(
        self, held: list[McapRecord], at: int, end: int, indexed: dict[int, list[int]]
    ) -> Iterator[McapRecord]:
        """The records of the chunk at byte ``at`` whose message indexes end at ``end``."""
        self.unit, self.in_chunk = (at, end), True
        if self._damage:
            damage, self._damage = self._damage, ''
            yield from self._confirmed(held, at, indexed, damage)
        else:
            yield from self._checked(held, at, indexed)

    def _confirmed(
        self, held: list[McapRecord], at: int, indexed: dict[int, list[int]], damage: str
    ) -> list[McapRecord]:
        """The records read from the start of a damaged chunk, its messages only while their
        log times match its message index, channel by channel (none without an index: nothing
        confirms them); what is not kept is listed in ``skipped``."""
        from mcap.records import Message  # noqa: PLC0415 (lazy: mcap, import time)

        kept: list[McapRecord] = []
        read = dict.fromkeys(indexed, 0)
        for record in held:
            if isinstance(record, Message):
                times = indexed.get(record.channel_id, [])
                done = read.get(record.channel_id, 0)
                if done >= len(times) or times[done] != record.log_time:
                    break  # not what was written: the damage starts here
                read[record.channel_id] = done + 1
            kept.append(record)
        lost = {c: len(times) - read[c] for c, times in indexed.items() if len(times) > read[c]}
        if not indexed:
            lost = {-1: -1}
        if lost:
            self.skipped.append((at, lost, damage))
        return kept

    def _checked(
        self, held: list[McapRecord], at: int, indexed: dict[int, list[int]]
    ) -> list[McapRecord]:
        """A chunk's records, without its messages when they do not match its message index
        (a chunk without CRC, damaged: what it parses into is not what was written)."""
        from mcap.records import Message  # noqa: PLC0415 (lazy: mcap, import time)

        if not indexed:
            return held
        found: dict[int, list[int]] = {}
        for record in held:
            if isinstance(record, Message):
                found.setdefault(record.channel_id, []).append(record.log_time)
        if all(sorted(found.get(c, [])) == sorted(times) for c, times in indexed.items()) and set(
            found
        ) <= set(indexed):
            return held
        lost = {channel: len(times) for channel, times in indexed.items()}
        self.skipped.append((at, lost, 'its messages do not match its message index'))
        return [record for record in held if not isinstance(record, Message)]


def _why(stream: BinaryIO, at: int, size: int, exc: Exception, *, cut: bool) -> str:
    """Why the record at byte ``at`` does not read, for a user: where a record runs past the
    file's end (of ``size`` bytes), that rather than the mcap library's text. ``cut``: the
    scan ends here (nothing readable follows), so the file's end is what cuts it."""
    from mcap.exceptions import EndOfFile  # noqa: PLC0415 (lazy: mcap, import time)
    from mcap.opcode import Opcode  # noqa: PLC0415 (lazy: mcap, import time)

    stream.seek(at)
    head = stream.read(RECORD.size)
    if len(head) < RECORD.size:
        if isinstance(exc, EndOfFile) and at >= size:
            return 'the file ends before its footer'
        return f'the file ends at byte {size}, inside the record at byte {at}'
    opcode, length = RECORD.unpack(head)
    try:
        kind = Opcode(opcode).name.lower().replace('_', ' ') + ' record'
    except ValueError:
        kind = f'record of opcode {opcode}'
    if at + RECORD.size + length <= size:
        return str(exc) or type(exc).__name__
    if cut:
        return (
            f'the file ends at byte {size}, inside the {kind} at byte {at} '
            f'({size - at} of its {RECORD.size + length} bytes present)'
        )
    return f"the {kind} at byte {at} declares {length} bytes, past the file's end at byte {size}"


def next_chunk(stream: BinaryIO, start: int) -> int | None:
    """The offset of the first record at or after ``start`` that is laid out as a chunk (its
    lengths add up, a known compression), for a scan to go on after a damaged record; None
    when there is none. The chunk itself may still fail its CRC."""
    with mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ) as data:
        found = _find_chunk(data, start)
    return found


def _find_chunk(data: mmap.mmap, at: int) -> int | None:
    while (found := data.find(bytes([CHUNK_OPCODE]), at)) >= 0:
        at = found + 1
        if found + CHUNK_HEAD.size > len(data):
            return None
        _, length, _, _, _, _, name_length = CHUNK_HEAD.unpack_from(data, found)
        name_at = found + CHUNK_HEAD.size
        if name_length > 4 or data[name_at : name_at + name_length] not in COMPRESSIONS:
            continue
        records_at = name_at + name_length
        if found + 9 + length > len(data) or records_at + 8 > len(data):
            continue
        (records,) = struct.unpack_from('<Q', data, records_at)
        if records_at + 8 + records == found + 9 + length:
            return found
    return None


class RecoveredMcap(Recovered):
    """The complete records of an MCAP file without summary, as a rosbags-like storage."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.connections: list[Connection] = []
        self.metadata: ReaderMetadata | None = None
        self.stopped_at = ''  #: why the scan stopped before the end ('' when it reached it)
        #: damaged chunks skipped: (offset, messages lost per channel id, why)
        self.skipped: list[tuple[int, dict[int, int], str]] = []
        self.in_order = True
        #: where the messages lie: (first time, last time, start byte, end byte) of each
        #: chunk, or run of messages outside chunks, that holds some
        self.units: list[tuple[int, int, int, int]] = []
        #: the schema encodings no ROS reader reads (neither ros2msg nor ros2idl), by channel id
        self.unknown_encodings: dict[int, str] = {}

    def _records(self, scan: LinearScan) -> Iterator[McapRecord]:
        yield from scan.records()
        self.stopped_at = scan.stopped_at
        self.skipped = scan.skipped

    def open(self) -> None:
        """Scan the file once for its schemas, channels, counts and times."""
        from mcap.records import Channel, Message, Schema  # noqa: PLC0415 (lazy: mcap, import time)
        from rosbags.interfaces import (  # noqa: PLC0415 (lazy: rosbags, import time)
            Connection,
            ConnectionExtRosbag2,
            MessageDefinition,
            MessageDefinitionFormat,
        )
        from rosbags.rosbag2.metadata import ReaderMetadata, parse_qos  # noqa: PLC0415 (lazy: rosbags, import time)

        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        counts: dict[int, int] = {}
        first, last, previous = None, None, None
        scan = LinearScan(self.path)
        run = 0  # the messages of the last unit, when it is a run outside chunks
        for record in self._records(scan):
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message):
                counts[record.channel_id] = counts.get(record.channel_id, 0) + 1
                stamp = record.log_time
                first = stamp if first is None else min(first, stamp)
                last = stamp if last is None else max(last, stamp)
                if previous is not None and stamp < previous:
                    self.in_order = False
                previous = stamp
                run = self._add(scan, stamp, run)
        for channel in channels.values():
            schema = schemas.get(channel.schema_id)
            form = _FORMATS.get(schema.encoding, 'NONE') if schema else 'NONE'
            if schema and schema.encoding and schema.encoding not in _FORMATS:
                self.unknown_encodings[channel.id] = schema.encoding
            text = schema.data.decode('utf-8', 'replace') if schema else ''
            self.connections.append(
                Connection(
                    channel.id,
                    channel.topic,
                    schema.name if schema else '',
                    MessageDefinition(MessageDefinitionFormat[form], text),
                    '',
                    counts.get(channel.id, 0),
                    ConnectionExtRosbag2(
                        channel.message_encoding,
                        parse_qos(channel.metadata.get('offered_qos_profiles', '')),
                    ),
                    self,
                )
            )
        count = sum(counts.values())
        self.metadata = ReaderMetadata(
            (last - first + 1) if count and first is not None and last is not None else 0,
            first if first is not None else 2**63 - 1,
            last + 1 if last is not None else 0,
            count,
            None,
            None,
            None,
            None,
        )

    def _add(self, scan: LinearScan, stamp: int, run: int) -> int:
        """Count a message at ``stamp`` into the unit it lies in (a chunk, or up to
        :data:`_RUN` messages in a row outside chunks); the messages of the run it is in."""
        begin, end = scan.unit
        units = self.units
        if units and (units[-1][2] == begin or (run and units[-1][3] == begin and run < _RUN)):
            low, high, begin, _ = units[-1]
            units[-1] = (min(low, stamp), max(high, stamp), begin, end)
            return run + 1 if run else 0
        units.append((stamp, stamp, begin, end))
        return 0 if scan.in_chunk else 1

    def close(self) -> None:
        """Nothing stays open between scans."""

    def _select(
        self, by_id: dict[int, Connection], start: int | None, stop: int | None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        from mcap.records import Message  # noqa: PLC0415 (lazy: mcap, import time)

        if self.in_order:
            yield from (
                (by_id[r.channel_id], r.log_time, r.data)
                for r in self._records(LinearScan(self.path))
                if isinstance(r, Message)
                and r.channel_id in by_id
                and within(r.log_time, start, stop)
            )
            return
        # out of time order: the units in the order of their first times, merged
        units = sorted(
            unit
            for unit in self.units
            if (start is None or unit[1] >= start) and (stop is None or unit[0] < stop)
        )

        def read(begin: int, end: int) -> list[Scanned]:
            found = LinearScan(self.path).records(begin, end)
            messages = (r for r in found if isinstance(r, Message))
            return [
                (r.log_time, begin, rank, r.channel_id, r.data)
                for rank, r in enumerate(messages)
                if r.channel_id in by_id and within(r.log_time, start, stop)
            ]

        for time, _, _, cid, data in merged((first, read(b, e)) for first, _, b, e in units):
            yield by_id[cid], time, data
