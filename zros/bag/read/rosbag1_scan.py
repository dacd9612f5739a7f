"""ROS 1 bags with damage: messages chunk by chunk, a damaged chunk or record skipped.

:func:`indexed_messages` reads an indexed bag as rosbags' reader does, but a chunk that does
not decompress, or a record that does not parse, is reported and skipped instead of ending the
read. :class:`ScannedBag1` reads a bag rosbags cannot open (cut short, so its index at the end
is gone, or a damaged index) in one pass over its records, with the interface of rosbags'
reader; connections come from the connection records each chunk holds. A last chunk that the
file's end cuts short gives the whole records of its part present (decompressed as a stream,
bz2 and lz4 alike, as :mod:`zros.bag.read.mcap_cut` does for MCAP; lz4 by
:mod:`zros.bag.read.lz4_part`): a recording interrupted
before its first chunk was finished is not lost whole.
"""

from __future__ import annotations

import io
import mmap
import os
import struct
from collections.abc import Callable, Collection, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

from zros.bag.read.lz4_part import decompress_part
from zros.bag.read.mcap_cut import describe_cut
from zros.bag.read.merge import Entry, Scanned, merged
from zros.bag.read.recovered import Recovered, within
from zros.bag.read.source_base import describe_error

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.rosbag1.reader import Header

    from zros.bag.read.rosbag1_index import IndexedBag1

#: a damaged unit: its byte offset, the messages lost per (native) connection id (-1 for an
#: unknown count of unknown connections: key -1), why
Damaged = Callable[[int, dict[int, int], str], None]
_MSGDATA, _IDXDATA, _CHUNK, _CHUNK_INFO, _CONNECTION = 2, 4, 5, 6, 7
#: the op field of a chunk record's header, as written
_CHUNK_OP = b'\x04\x00\x00\x00op=\x05'
#: how far before its op field a chunk record may start (header length, other fields)
_BEFORE_OP = 64


def indexed_messages(
    reader: IndexedBag1,
    wanted: Collection[Connection],
    start: int | None,
    stop: int | None,
    damaged: Damaged,
) -> Iterator[tuple[Connection, int, bytes]]:
    """``(connection, time, data)`` of ``wanted`` in time order, as ``reader.messages``; a chunk
    that does not decompress or a record that does not parse is reported to ``damaged``."""
    from rosbags.rosbag1.reader import Header, read_bytes, read_uint32  # noqa: PLC0415 (lazy: rosbags, import time)

    assert reader.bio is not None, 'the reader is not open'
    bio = reader.bio
    connmap = {c.id: c for c in reader.connections}
    bad: set[int] = set()
    current, chunk = -1, io.BytesIO()
    for time, position, offset, cid in _entries(reader, {c.id for c in wanted}, start, stop):
        if start is not None and time < start:
            continue
        if stop is not None and time >= stop:
            return
        if position in bad:
            continue
        if position != current:
            header = reader.chunks[position]
            try:
                bio.seek(header.datapos)
                chunk = io.BytesIO(header.decompressor(read_bytes(bio, header.datasize)))
            except Exception as exc:  # the decompressors raise what they like
                bad.add(position)
                damaged(position, _in_chunk(reader, wanted, position, start, stop), why(exc))
                continue
            current = position
        try:
            chunk.seek(offset)
            while True:
                record = Header.read(chunk)
                have = record.get_uint8('op')
                if have != _CONNECTION:
                    break
                chunk.seek(read_uint32(chunk), os.SEEK_CUR)
            if have != _MSGDATA or record.get_time('time') != time:
                raise ValueError('no message record where the index says')
            data = read_bytes(chunk, read_uint32(chunk))
            connection = connmap[record.get_uint32('conn')]
        except Exception as exc:  # flipped bytes: anything from struct, rosbags, a lookup
            damaged(position, {cid: 1}, f'the record at byte {offset} of the chunk: {why(exc)}')
            continue
        reader.position = position
        yield connection, time, data


def _entries(
    reader: IndexedBag1, ids: set[int], start: int | None, stop: int | None
) -> Iterator[Entry]:
    """``(time, chunk position, offset in the chunk, connection id)`` of the messages of
    connections ``ids``, in time order, reading each chunk's index as the read reaches it."""
    infos = sorted(
        (
            info
            for info in reader.chunk_infos
            if ids & info.connection_counts.keys()
            and (start is None or info.end_time > start)
            and (stop is None or info.start_time < stop)
        ),
        key=lambda info: (info.start_time, info.pos),
    )

    def entries(position: int) -> list[Entry]:
        return [
            (entry.time, entry.chunk_pos, entry.offset, cid)
            for cid, found in reader.chunk_index(position).items()
            if cid in ids
            for entry in found
        ]

    return merged((info.start_time, entries(info.pos)) for info in infos)


def _in_chunk(
    reader: IndexedBag1,
    wanted: Collection[Connection],
    position: int,
    start: int | None,
    stop: int | None,
) -> dict[int, int]:
    index = reader.chunk_index(position)
    counts = {
        connection.id: sum(
            1
            for entry in index.get(connection.id, ())
            if (start is None or entry.time >= start) and (stop is None or entry.time < stop)
        )
        for connection in wanted
    }
    return {cid: count for cid, count in counts.items() if count}


def why(exc: BaseException) -> str:
    """The text of an error reading damaged data (a bare AssertionError or KeyError says
    nothing: it becomes what it means)."""
    text = ' '.join(describe_error(exc).split())  # one line
    if isinstance(exc, AssertionError | KeyError | IndexError) or text == type(exc).__name__:
        return f'the data does not parse, damaged ({type(exc).__name__}: {text})'
    return text


class _Unreadable(Exception):
    """A record that cannot be read: the scan stops there. ``op``: the record's type where
    its header could be read."""

    def __init__(self, text: str, op: int | None = None) -> None:
        super().__init__(text)
        self.op = op


class ScannedBag1(Recovered):
    """The records of a ROS 1 bag read in one pass (for a bag rosbags cannot open), with the
    interface of rosbags' reader. After :meth:`open`, ``losses`` lists the damaged chunks
    (offset, lost per connection id, why) and ``stopped_at`` why the scan ended before the end
    of the file ('' when it reached it)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.connections: list[Connection] = []
        self.losses: list[tuple[int, dict[int, int], str]] = []
        self.stopped_at = ''
        self.start_time = 2**63 - 1
        self.end_time = 0
        self.compression = 'none'  #: the first chunk's
        self._chunked = False
        #: the chunks with messages: (first time, last time, byte offset), read again by a read
        self._chunks: list[tuple[int, int, int]] = []
        self._cut = -1  #: the byte offset of a last chunk the file's end cuts short
        #: the byte offset of the chunk of the message a read handed on last
        self.position = 0
        #: the byte offset of the first chunk holding messages of each connection id
        self.first_chunk: dict[int, int] = {}

    def open(self) -> None:
        """Read every record that can be read."""
        from rosbags.rosbag1.reader import ReaderError  # noqa: PLC0415 (lazy: rosbags, import time)

        headers: dict[int, tuple[Header, Header]] = {}
        counts: dict[int, int] = {}
        with self.path.open('rb') as stream:
            size = os.fstat(stream.fileno()).st_size
            if not stream.readline().startswith(b'#ROSBAG V2.0'):
                raise ReaderError('not a ROS 1 bag (version 2.0)')
            chunk_read: dict[int, int] = {}  # messages read per connection from the last chunk
            loss: tuple[int, dict[int, int], str] | None = None
            while stream.tell() < size:
                at = stream.tell()
                try:
                    header, data = _record(stream, size)
                    op = header.get_uint8('op')
                except (_Unreadable, ReaderError, struct.error) as exc:
                    if loss is not None and not loss[1]:
                        loss[1][-1] = -1  # no index after the damaged chunk: count unknown
                    loss = None
                    if getattr(exc, 'op', None) == _CHUNK:  # the file ends inside this chunk
                        messages, cut = self._read_cut(stream, at, size, headers)
                        self._cut = at
                        self._add(at, messages, counts)
                        self.losses.append((at, {-1: -1}, cut))  # it reached the file's end
                        break
                    # the index at the end holds no messages: a scan cut there lost none
                    if getattr(exc, 'op', None) not in (_CONNECTION, _CHUNK_INFO):
                        self.losses.append((at, {-1: -1}, describe_error(exc)))
                    following = _next_chunk(stream, at + 1, size)
                    if following is None:
                        self.stopped_at = f'byte {at}: {describe_error(exc)}'
                        break
                    stream.seek(following)
                    continue
                if loss is not None and not loss[1] and op != _IDXDATA:
                    loss[1][-1] = -1  # no index after the damaged chunk: count unknown
                try:
                    if op == _CHUNK:
                        messages, problem = self._chunk(header, data, headers)
                        chunk_read = {}
                        for _, cid, _ in messages:
                            chunk_read[cid] = chunk_read.get(cid, 0) + 1
                        self._add(at, messages, counts)
                        loss = (at, {}, problem) if problem else None
                        if loss is not None:
                            self.losses.append(loss)
                    elif op == _IDXDATA and loss is not None:
                        conn, count = header.get_uint32('conn'), header.get_uint32('count')
                        if count > chunk_read.get(conn, 0):
                            loss[1][conn] = count - chunk_read.get(conn, 0)
                    elif op == _CONNECTION:
                        headers.setdefault(header.get_uint32('conn'), (header, _fields(data)))
                except ReaderError:
                    continue  # a damaged index or connection record: the chunks tell
            else:
                if loss is not None and not loss[1]:
                    loss[1][-1] = -1
        for cid, pair in headers.items():
            try:
                self.connections.append(_connection(self, cid, *pair, counts.get(cid, 0)))
            except Exception as exc:  # a damaged connection record: its messages are lost
                reason = f'the record of connection {cid}: {why(exc)}'
                self.losses.append((self.first_chunk.get(cid, 0), {-1: counts.get(cid, 0)}, reason))

    def _add(self, at: int, messages: list[tuple[int, int, bytes]], counts: dict[int, int]) -> None:
        """Count the messages read from the chunk at byte ``at``; remember where it lies."""
        if not messages:
            return
        times = [time for time, _, _ in messages]
        first, last = min(times), max(times)
        self._chunks.append((first, last, at))
        self.start_time, self.end_time = min(self.start_time, first), max(self.end_time, last + 1)
        for _, cid, _ in messages:
            counts[cid] = counts.get(cid, 0) + 1
            self.first_chunk.setdefault(cid, at)

    def _read_cut(
        self, stream: BinaryIO, at: int, size: int, headers: dict[int, tuple[Header, Header]]
    ) -> tuple[list[tuple[int, int, bytes]], str]:
        """Read the chunk at byte ``at`` that the file's end (at ``size``) cuts short: its
        messages (as :meth:`_chunk`) and what was read of it, as a sentence."""
        from rosbags.rosbag1.reader import Header  # noqa: PLC0415 (lazy: rosbags, import time)

        stream.seek(at)
        header = Header.read(stream)
        (length,) = struct.unpack('<L', stream.read(4))
        total = stream.tell() + length - at
        data = stream.read(size - stream.tell())  # less than the chunk: memory holds one
        messages, problem = self._chunk(header, data, headers, cut=True)
        return messages, describe_cut(at, size, total, len(messages), problem)

    def _chunk(
        self,
        header: Header,
        data: bytes,
        headers: dict[int, tuple[Header, Header]],
        cut: bool = False,
    ) -> tuple[list[tuple[int, int, bytes]], str]:
        """Read a chunk's records: its messages (time, connection id, data) up to the first
        record that does not parse, and what went wrong (''). A ``cut`` chunk's ``data`` is
        the part of it present: what it decompresses to so far is read up to its last whole
        record."""
        from rosbags.rosbag1.reader import decompressors  # noqa: PLC0415 (lazy: rosbags, import time)

        read: list[tuple[int, int, bytes]] = []
        try:
            compression = header.get_string('compression')
            if not self._chunked:
                self._chunked = True
                self.compression = compression
            if compression not in decompressors:
                return read, f'compression {compression!r} unknown'
            if cut:
                inner = _decompressed_part(compression, data, header.get_uint32('size'))
            else:
                inner = decompressors[compression](data)
        except Exception as exc:  # the decompressors raise what they like
            return read, why(exc)
        stream = io.BytesIO(inner)
        try:
            while stream.tell() < len(inner):
                record, payload = _record(stream, len(inner))
                op = record.get_uint8('op')
                if op == _CONNECTION:
                    headers.setdefault(record.get_uint32('conn'), (record, _fields(payload)))
                elif op == _MSGDATA:
                    read.append((record.get_time('time'), record.get_uint32('conn'), payload))
        except _Unreadable as exc:
            if not cut:  # else the end of the part present
                return read, f'a record in the chunk: {why(exc)}'
        except Exception as exc:  # flipped bytes: anything from struct or rosbags
            return read, f'a record in the chunk: {why(exc)}'
        return read, ''

    def close(self) -> None:
        """Nothing stays open."""

    def _select(
        self, by_id: dict[int, Connection], start: int | None, stop: int | None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """The messages, a chunk at a time: chunks in the order of their first times, a
        message handed on once no chunk still to read can hold an earlier one (in file order
        among equal times)."""
        chunks = sorted(
            chunk
            for chunk in self._chunks
            if (start is None or chunk[1] >= start) and (stop is None or chunk[0] < stop)
        )
        with self.path.open('rb') as stream:
            size = os.fstat(stream.fileno()).st_size

            def read(at: int) -> list[Scanned]:
                stream.seek(at)
                if at == self._cut:
                    messages, _ = self._read_cut(stream, at, size, {})
                else:
                    header, data = _record(stream, size)
                    messages, _ = self._chunk(header, data, {})  # its damage was counted at open
                return [
                    (time, at, rank, cid, payload)
                    for rank, (time, cid, payload) in enumerate(messages)
                    if cid in by_id and within(time, start, stop)
                ]

            for time, at, _, cid, data in merged((first, read(at)) for first, _, at in chunks):
                self.position = at
                yield by_id[cid], time, data


def _decompressed_part(compression: str, data: bytes, declared: int) -> bytes:
    """What the part present of a chunk compressed with ``compression`` decompresses to so far
    (at most the chunk's ``declared`` size: more is damage)."""
    if compression == 'bz2':
        import bz2  # noqa: PLC0415 (only for bz2 chunks)

        inner: bytes = bz2.BZ2Decompressor().decompress(data, max_length=declared + 1)
    elif compression == 'lz4':  # lz4.frame gives nothing of a block cut short
        inner = decompress_part(data, declared)
    else:
        inner = data
    if len(inner) > declared:
        raise ValueError('it decompresses to more than its header declares')
    return inner


def _record(stream: BinaryIO, size: int) -> tuple[Header, bytes]:
    """The header and data of the record at the stream's position."""
    from rosbags.rosbag1.reader import Header  # noqa: PLC0415 (lazy: rosbags, import time)

    at = stream.tell()
    head = stream.read(4)
    if len(head) < 4:
        raise _Unreadable('the file ends inside a record')
    (length,) = struct.unpack('<L', head)
    if at + 4 + length + 4 > size:
        raise _Unreadable(f'a record header of {length} bytes runs past the end')
    stream.seek(at)
    header = Header.read(stream)
    (length,) = struct.unpack('<L', stream.read(4))
    if stream.tell() + length > size:
        op = header.get_uint8('op') if 'op' in header else None
        raise _Unreadable(f'a record of {length} bytes runs past the end (cut short)', op)
    return header, stream.read(length)


def _next_chunk(stream: BinaryIO, start: int, size: int) -> int | None:
    """The offset of the first readable chunk record at or after ``start`` (None: none); the
    file is searched through a map, not read into memory."""
    with mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ) as data:
        at = start
        while (found := data.find(_CHUNK_OP, at)) >= 0:
            at = found + 1
            for begin in range(max(start, found - _BEFORE_OP), found):
                (length,) = struct.unpack_from('<L', data, begin)
                if not begin + 4 <= found < begin + 4 + length <= len(data):
                    continue
                stream.seek(begin)
                try:
                    header, _ = _record(stream, size)
                    if header.get_uint8('op') == _CHUNK:
                        return begin
                except Exception:
                    continue
    return None


def _fields(data: bytes) -> Header:
    from rosbags.rosbag1.reader import Header  # noqa: PLC0415 (lazy: rosbags, import time)

    return Header.read(io.BytesIO(struct.pack('<L', len(data)) + data))


def _connection(
    owner: ScannedBag1, cid: int, header: Header, fields: Header, count: int
) -> Connection:
    from rosbags.interfaces import (  # noqa: PLC0415 (lazy: rosbags, import time)
        Connection,
        ConnectionExtRosbag1,
        MessageDefinition,
        MessageDefinitionFormat,
    )
    from rosbags.rosbag1.reader import normalize  # noqa: PLC0415 (lazy: rosbags, import time)
    from rosbags.typesys.msg import normalize_msgtype  # noqa: PLC0415 (lazy: rosbags, import time)

    latching = fields.get_string('latching') if 'latching' in fields else ''
    return Connection(
        cid,
        normalize(header.get_string('topic')),
        normalize_msgtype(fields.get_string('type')),
        MessageDefinition(MessageDefinitionFormat.MSG, fields.get_string('message_definition')),
        fields.get_string('md5sum'),
        count,
        ConnectionExtRosbag1(
            fields.get_string('callerid') if 'callerid' in fields else None,
            int(latching) if latching else None,
        ),
        owner,  # a reader in all but name
    )
