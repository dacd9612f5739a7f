"""Whole chunks of an indexed MCAP file: the messages of chosen channels without a Python step
per message record.

The mcap library reads the summary and the chunk records; each chunk's message index gives the
offset of every message of a channel, so times, lengths and positions of its messages are numpy
arrays and the payloads are offsets into the decompressed chunk (or the file's map). Files
without a summary or message indexes, or whose indexes do not add up, are refused with
:class:`Unsupported`: the caller then reads them record by record through rosbags.
"""

from __future__ import annotations

import io
import mmap
import struct
import zlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from zros.bag.errors import Unsupported
from zros.bag.read.mcap_cut import intact_start, read_part
from zros.bag.read.payloads import Payloads
from zros.bag.read.source_base import Block, Connection, describe_error

if TYPE_CHECKING:
    import numpy.typing as npt
    from mcap.records import Chunk, ChunkIndex

#: opcodes of the MCAP records this module reads
_CHUNK = 0x06
_MESSAGE = 0x05
_MESSAGE_INDEX = 0x07
#: a message record before its data: opcode, length, channel, sequence, log and publish time
_HEAD = 1 + 8 + 2 + 4 + 8 + 8
#: a decompressed chunk larger than this is not trusted to the fast path
_MAX_CHUNK = 1 << 31
_INDEX = np.dtype([('time', '<u8'), ('offset', '<u8')])
#: what a reader is told of a chunk it cannot read: its offset, the messages lost per channel
#: (-1: unknown), why
Damaged = Callable[[int, dict[int, int], str], None]
#: refusals that mean the chunk's bytes are damaged (others: the fast path cannot read it)
_DAMAGE = ('damaged chunk record', 'chunk size does not match', 'no chunk where')


def _damaged_chunk(exc: Exception, chunk: Chunk | None) -> bool:
    """Whether a chunk that failed to read is damaged (else: the fast path cannot read it, and
    the caller hands it to a reader that can). Where its messages do not match their index,
    the chunk's CRC tells (checked only then: it costs a pass over the chunk)."""
    if not isinstance(exc, Unsupported):
        return True  # a decompression or parse error
    if str(exc).startswith(_DAMAGE):
        return True
    if chunk is None or not str(exc).startswith('message index'):
        return False
    if not chunk.uncompressed_crc:
        return True  # no CRC to tell (rosbags writes none): the records are not where indexed
    try:
        data = _decompress(chunk)
    except Exception:
        return True
    return zlib.crc32(data) != chunk.uncompressed_crc


@dataclass
class _Run:
    """Messages of one channel in one chunk, in the chunk's order."""

    times: npt.NDArray[np.int64]  #: log times
    offsets: npt.NDArray[np.int64]  #: record offsets in the chunk (ascending)
    data: Payloads


def _mapped_chunk(view: memoryview, at: int) -> Chunk:
    """The Chunk record at ``at`` of a mapped file, its records a view of the map."""
    from mcap.records import Chunk  # noqa: PLC0415 (lazy: mcap, import time)

    try:
        if view[at] != _CHUNK:
            raise Unsupported('no chunk where the chunk index says')
        head = at + 1 + 8  # past the opcode and the record's length
        first, last, size, crc, name_length = struct.unpack_from('<QQQII', view, head)
        compression = bytes(view[head + 32 : head + 32 + name_length]).decode()
        (length,) = struct.unpack_from('<Q', view, head + 32 + name_length)
    except (IndexError, struct.error, UnicodeDecodeError) as exc:
        raise Unsupported(f'damaged chunk record: {exc}') from None
    begin = head + 32 + name_length + 8
    if begin + length > len(view):
        raise Unsupported('chunk beyond the end of the file')
    return Chunk(
        compression=compression,
        data=view[begin : begin + length],  # type: ignore[arg-type]  # read as bytes-like
        message_start_time=first,
        message_end_time=last,
        uncompressed_crc=crc,
        uncompressed_size=size,
    )


def _decompress(chunk: Chunk) -> bytes | memoryview:
    if chunk.uncompressed_size > _MAX_CHUNK:
        raise Unsupported('chunk too large')
    if chunk.compression == '':
        data = chunk.data  # bytes, or a view of a mapped file
    elif chunk.compression == 'zstd':
        import zstandard  # noqa: PLC0415 (only for zstd chunks)

        data = zstandard.ZstdDecompressor().decompress(
            chunk.data, max_output_size=chunk.uncompressed_size
        )
    elif chunk.compression == 'lz4':
        import lz4.frame  # type: ignore[import-untyped]  # noqa: PLC0415 (only for lz4 chunks)

        data = lz4.frame.decompress(chunk.data)
    else:
        raise Unsupported(f'compression {chunk.compression!r}')
    if len(data) != chunk.uncompressed_size:
        raise Unsupported('chunk size does not match its index')
    return data


def _index(stream: io.BufferedReader, at: int, limit: int) -> npt.NDArray[np.void]:
    """The (time, offset) entries of the MessageIndex record at ``at``."""
    stream.seek(at)
    head = stream.read(1 + 8 + 2 + 4)
    if len(head) < 15 or head[0] != _MESSAGE_INDEX:
        raise Unsupported('no message index record where the chunk index says')
    size = int.from_bytes(head[11:15], 'little')
    if at + 15 + size > limit or size % 16:
        raise Unsupported('message index out of bounds')
    return np.frombuffer(stream.read(size), _INDEX)


def read_blocks(
    path: Path,
    channels: Mapping[int, Connection],
    start: int | None,
    end: int | None,
    *,
    mapped: bool = False,
    damaged: Damaged | None = None,
) -> Iterator[list[Block]]:
    """The blocks of each chunk holding messages of ``channels`` (channel id -> the connection
    its blocks carry) with ``start <= log time < end``, in file order (chunks may overlap in
    time: the caller sorts); a block's ``keys`` rank its messages in their chunk.
    ``mapped``: each chunk is memory-mapped and the payloads of uncompressed chunks stay in its
    map (no copy: for readers that copy out a few fields of each message); else chunks are
    read into memory. ``damaged``: a chunk that does not read or decompress is skipped and
    reported to it (else it raises)."""
    for _, blocks in _chunk_blocks(
        path, channels, start, end, by_start=False, mapped=mapped, damaged=damaged
    ):
        yield blocks


def _chunk_blocks(
    path: Path,
    channels: Mapping[int, Connection],
    start: int | None,
    end: int | None,
    *,
    by_start: bool,
    mapped: bool,
    damaged: Damaged | None,
) -> Iterator[tuple[int, list[Block]]]:
    """:func:`read_blocks`, each chunk's blocks with the chunk's first log time (of any
    channel); ``by_start``: chunks in the order of their first log times, not in file order.
    ``mapped``: each chunk is memory-mapped and the payloads of uncompressed chunks stay in its
    map (no copy: for readers that copy out a few fields of each message); else chunks are
    read into memory. ``damaged``: a chunk that does not read or decompress is skipped and
    reported to it (else it raises)."""
    from mcap.data_stream import ReadDataStream  # noqa: PLC0415 (lazy: mcap, import time)
    from mcap.reader import make_reader  # noqa: PLC0415 (lazy: mcap, import time)
    from mcap.records import Chunk  # noqa: PLC0415 (lazy: mcap, import time)

    with path.open('rb') as stream:
        size = path.stat().st_size
        try:
            summary = make_reader(stream).get_summary()
        except Exception as exc:  # a damaged summary: the caller reads the file another way
            raise Unsupported(str(exc)) from exc
        if summary is None or not summary.chunk_indexes:
            raise Unsupported('no chunk index')
        wanted_ids = set(channels)
        indexes = [
            index
            for index in sorted(summary.chunk_indexes, key=_by_start if by_start else _by_offset)
            if wanted_ids & set(index.message_index_offsets)
            and (start is None or index.message_end_time >= start)
            and (end is None or index.message_start_time < end)
        ]
        for index in indexes:
            wanted = sorted(wanted_ids & set(index.message_index_offsets))
            limit = index.chunk_start_offset + index.chunk_length + index.message_index_length
            if limit > size:
                raise Unsupported('chunk beyond the end of the file')
            window = None
            at = index.chunk_start_offset
            if mapped:
                # a map of this chunk alone, closed when the last payload in it is gone: the
                # process maps the chunks it holds, never the whole file (a failing map is the
                # system's error, not the file's damage)
                base = at - at % mmap.ALLOCATIONGRANULARITY
                window = mmap.mmap(
                    stream.fileno(),
                    at + index.chunk_length - base,
                    access=mmap.ACCESS_READ,
                    offset=base,
                )
            chunk: Chunk | None = None
            try:
                if window is not None:
                    chunk = _mapped_chunk(memoryview(window), at - base)
                else:
                    stream.seek(index.chunk_start_offset + 1 + 8)
                    chunk = Chunk.read(ReadDataStream(stream))
                data = _decompress(chunk)
                runs = [
                    _window(
                        _block(
                            data,
                            channel,
                            _index(stream, index.message_index_offsets[channel], limit),
                        ),
                        start,
                        end,
                    )
                    for channel in wanted
                ]
            except Exception as exc:  # the compression libraries raise what they like
                if damaged is None or not _damaged_chunk(exc, chunk):
                    raise
                runs, lost, part = _intact_runs(
                    stream, index, chunk, wanted=wanted, limit=limit, start=start, end=end
                )
                if lost:
                    damaged(index.chunk_start_offset, lost, f'{describe_error(exc)}; {part}')
                if not any(len(run.times) for run in runs):
                    continue
            offsets = np.concatenate([run.offsets for run in runs])
            ranks = np.empty(len(offsets), np.int64)
            ranks[np.argsort(offsets, kind='stable')] = np.arange(len(offsets))
            blocks = []
            at = 0
            for channel, run in zip(wanted, runs, strict=True):
                keys = ranks[at : at + len(run.offsets)]
                blocks.append(Block(channels[channel], run.times, keys, run.data))
                at += len(run.offsets)
            yield index.message_start_time, blocks


def ordered_messages(
    path: Path,
    channels: Mapping[int, Connection],
    start: int | None,
    end: int | None,
    damaged: Damaged | None = None,
) -> Iterator[tuple[Connection, int, bytes]]:
    """``(connection, log time, payload)`` of the messages of ``channels`` with ``start <= log time
    < end``, in time order (file order among equal times), chunk by chunk.

    Chunks are read in the order of their first log times; a message is handed on once no
    chunk still to be read can hold an earlier one, so chunks that overlap in time are merged
    and only the overlap is held. Raises :class:`Unsupported` where :func:`read_blocks` refuses
    the file, possibly after some messages where a chunk's index does not match it.
    """
    pending = _Pending()
    for first, blocks in _chunk_blocks(
        path, channels, start, end, by_start=True, mapped=False, damaged=damaged
    ):
        yield from pending.before(first)
        pending.add(blocks)
    yield from pending.before(None)


class _Pending:
    """Messages read and not yet handed on: log times, file positions (chunk, rank), payloads."""

    def __init__(self) -> None:
        self.times = np.empty(0, np.int64)
        self.keys = np.empty(0, np.int64)
        self.connections: list[Connection] = []
        self.payloads: list[bytes] = []
        self.chunks = 0

    def add(self, blocks: list[Block]) -> None:
        """The blocks of the next chunk read."""
        self.chunks += 1
        self.times = np.concatenate([self.times, *(block.times for block in blocks)])
        keys = [(self.chunks << 40) + block.keys for block in blocks]  # chunk, then rank
        self.keys = np.concatenate([self.keys, *keys])
        for block in blocks:
            self.connections.extend([block.connection] * len(block.data))
            self.payloads.extend(block.data)

    def before(self, time: int | None) -> Iterator[tuple[Connection, int, bytes]]:
        """The messages earlier than ``time`` (all with None), in time and file order."""
        order = np.lexsort((self.keys, self.times))
        if time is not None:
            order = order[self.times[order] < time]
        if not len(order):
            return
        stamps = self.times.tolist()
        connections, payloads = self.connections, self.payloads
        keep = np.ones(len(self.times), bool)
        keep[order] = False
        rest = np.flatnonzero(keep).tolist()
        self.times, self.keys = self.times[keep], self.keys[keep]
        self.connections = [connections[at] for at in rest]
        self.payloads = [payloads[at] for at in rest]
        for at in order.tolist():
            yield connections[at], stamps[at], payloads[at]


def _by_offset(index: ChunkIndex) -> int:
    return int(index.chunk_start_offset)


def _by_start(index: ChunkIndex) -> tuple[int, int]:
    return int(index.message_start_time), int(index.chunk_start_offset)


def _in_window(
    times: npt.NDArray[np.int64], start: int | None, end: int | None
) -> npt.NDArray[np.bool_]:
    keep = np.ones(len(times), bool)
    if start is not None:
        keep &= times >= start
    if end is not None:
        keep &= times < end
    return keep


def _window(run: _Run, start: int | None, end: int | None) -> _Run:
    keep = _in_window(run.times, start, end)
    if keep.all():
        return run
    return _Run(run.times[keep], run.offsets[keep], run.data.select(keep))


def _intact_runs(
    stream: io.BufferedReader,
    index: ChunkIndex,
    chunk: Chunk | None,
    *,
    wanted: list[int],
    limit: int,
    start: int | None,
    end: int | None,
) -> tuple[list[_Run], dict[int, int], str]:
    """The messages in the window at the start of a damaged chunk that its message index
    confirms (each channel's records where its index says, up to the first that is not, among
    the records read before the damage), the count of each channel's not kept (-1: its index
    does not read either), and what was read, for a user."""
    if chunk is None:
        intact, part = b'', 'its record does not read'
    else:
        read, _, intact = intact_start(index.chunk_start_offset, chunk)
        part = read_part(read)
    raw = np.frombuffer(intact, np.uint8)  # memory: one chunk
    runs: list[_Run] = []
    lost: dict[int, int] = {}
    for channel in wanted:
        try:
            entries = _index(stream, index.message_index_offsets[channel], limit)
        except Unsupported:
            lost[channel] = -1
            nothing = np.empty(0, np.int64)
            runs.append(_Run(nothing, nothing, Payloads(intact, nothing, nothing)))
            continue
        entries = entries[np.argsort(entries['offset'], kind='stable')]
        good = _matching(raw, channel, entries)
        kept = len(good) if good.all() else int(np.argmin(good))
        run = _window(_block(intact, channel, entries[:kept]), start, end)
        total = int(_in_window(entries['time'].astype(np.int64), start, end).sum())
        if total > len(run.times):
            lost[channel] = total - len(run.times)
        runs.append(run)
    return runs, lost, part


def _matching(
    raw: npt.NDArray[np.uint8], channel: int, entries: npt.NDArray[np.void]
) -> npt.NDArray[np.bool_]:
    """Which of a channel's index entries point at a message record of it in ``raw``, of the
    time the index says."""
    times = entries['time'].astype(np.int64)
    offsets = entries['offset'].astype(np.int64)
    good = np.zeros(len(offsets), np.bool_)
    inside = np.flatnonzero((offsets >= 0) & (offsets + _HEAD <= len(raw)))
    good[inside] = _records_match(raw, channel, offsets[inside], times[inside])[0]
    return good


def _records_match(
    raw: npt.NDArray[np.uint8],
    channel: int,
    offsets: npt.NDArray[np.int64],
    times: npt.NDArray[np.int64],
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.int64]]:
    """Whether each offset (all inside ``raw``) holds a message record of ``channel`` at its
    time, and the records' lengths."""
    heads = raw[offsets[:, None] + np.arange(_HEAD)]
    lengths = heads[:, 1:9].copy().view('<u8')[:, 0].astype(np.int64)
    recorded = heads[:, 15:23].copy().view('<u8')[:, 0].astype(np.int64)
    good = (
        (heads[:, 0] == _MESSAGE)
        & (heads[:, 9:11].copy().view('<u2')[:, 0] == channel)
        & (lengths >= _HEAD - 9)
        & (offsets + 9 + lengths <= len(raw))
        & (recorded == times)
    )
    return good, lengths


def _block(data: bytes | memoryview, channel: int, entries: npt.NDArray[np.void]) -> _Run:
    entries = entries[np.argsort(entries['offset'], kind='stable')]
    times = entries['time'].astype(np.int64)
    offsets = entries['offset'].astype(np.int64)
    raw = np.frombuffer(data, np.uint8)
    if len(offsets) and (offsets.min() < 0 or offsets.max() + _HEAD > len(raw)):
        raise Unsupported('message offset out of the chunk')
    good, lengths = _records_match(raw, channel, offsets, times)
    if not good.all():
        raise Unsupported('message index does not match the chunk')
    return _Run(times, offsets, Payloads(data, offsets + _HEAD, offsets + 9 + lengths))
