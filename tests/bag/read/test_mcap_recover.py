"""An MCAP file without summary whose chunks are out of time order is read in time order, a
chunk at a time: memory does not grow with the recording, and a damaged chunk costs only its
own messages. A last chunk that the file's end cuts short keeps the whole messages of its part
present, and the reason the read stopped says so."""

from __future__ import annotations

import hashlib
import json
import logging
import struct
import sys
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from tests.bag.makebags import make_points_mcap
from tests.bag.read.test_damage import zero_a_chunk
from zros.bag import Bag, reindex
from zros.bag.read.mcap_recover import LinearScan, RecoveredMcap
from zros.testing import peak_memory

if TYPE_CHECKING:
    from mcap.records import ChunkIndex as Chunk

Messages = list[tuple[str, int, bytes]]
MB = 1 << 20
#: what the peak may grow by from 50,000 messages to 250,000 (held whole and sorted, the
#: 200,000 more took about 50 MB)
SLACK = 8 * MB


def _shuffled_mcap(
    path: Path, count: int, size: int = 16, chunk_size: int = 1 << 12
) -> tuple[Path, Messages]:
    """Three topics written one after the other in 4 KB zstd chunks, so chunks overlap in
    time and later chunks start earlier: /a every 10 ns, /b at the same times as /a (ties
    across chunks), /c going back in time in pairs of equal times (ties inside a chunk). The
    messages in the order a reader must give them: time, then file order."""
    from mcap.writer import CompressionType, Writer

    written: list[tuple[int, int, str, bytes]] = []
    with path.open('wb') as stream:
        writer = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        writer.start(profile='ros2', library='zros tests')
        schema = writer.register_schema('std_msgs/msg/String', 'ros2msg', b'string data\n')
        for topic in ('/a', '/b', '/c'):
            channel = writer.register_channel(topic, 'cdr', schema)
            for index in range(count):
                if topic == '/c':
                    stamp = 1000 + 10 * count - 15 * (index // 2)
                else:
                    stamp = 1000 + 10 * index
                text = f'{topic} {index}'.encode().ljust(size, b'.')
                data = struct.pack('<I', 0x100) + struct.pack('<I', len(text) + 1) + text + b'\0'
                writer.add_message(channel, log_time=stamp, data=data, publish_time=stamp)
                written.append((stamp, len(written), topic, data))
        writer.finish()
    return path, [(topic, stamp, data) for stamp, _, topic, data in sorted(written)]


def _cut_summary(path: Path) -> Path:
    """The file cut where its summary starts (as a recorder killed before writing it)."""
    data = path.read_bytes()
    (summary_start,) = struct.unpack_from('<Q', data, len(data) - 8 - 20)
    assert 0 < summary_start < len(data)
    path.write_bytes(data[:summary_start])
    return path


def _read(path: Path) -> Messages:
    with Bag(path) as bag:
        return [(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()]


def test_chunks_out_of_time_order_without_summary_read_in_time_order(tmp_path: Path) -> None:
    path, truth = _shuffled_mcap(tmp_path / 'shuffled.mcap', 2000)
    _cut_summary(path)
    recovered = RecoveredMcap(path)
    recovered.open()
    assert not recovered.in_order and len(recovered.units) > 10
    assert _read(path) == truth
    with Bag(path) as bag:  # a window: only the chunks it overlaps, still in order
        window = [(r.connection.topic, r.timestamp) for r in bag.raw_messages(start=5000, end=9000)]
    assert window == [(t, s) for t, s, _ in truth if 5000 <= s < 9000]


def test_messages_outside_chunks_out_of_time_order_read_in_time_order(tmp_path: Path) -> None:
    # no chunks: runs of messages are read again as units
    path = make_points_mcap(tmp_path / 'loose.mcap', 3500, chunked=False, shuffle=True)
    _cut_summary(path)
    recovered = RecoveredMcap(path)
    recovered.open()
    assert not recovered.in_order and len(recovered.units) == 4  # runs of 1000 at most
    with Bag(path) as bag:
        stamps = [r.timestamp for r in bag.raw_messages()]
        xs = [m.x for _, _, m in bag.messages()]
    expected = sorted((1000 + i * 10 - (15 if i % 7 == 6 else 0), i) for i in range(3500))
    assert stamps == [s for s, _ in expected]
    assert xs == [float(i) for _, i in expected]


def test_a_damaged_chunk_of_a_file_out_of_order_costs_only_its_messages(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path, truth = _shuffled_mcap(tmp_path / 'shuffled.mcap', 2000)
    offset, lost = zero_a_chunk(path)
    _cut_summary(path)
    assert lost
    with caplog.at_level(logging.WARNING, 'zros.bag'), Bag(path) as bag:
        got = [(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()]
        skipped = bag.skipped
    assert got == [m for m in truth if m not in lost]
    assert {(s.offset, s.lost) for s in skipped} == {(offset, len(lost))}


#: read every message, checking their order, without holding them
READ = """
import json, sys
from zros.bag import Bag
with Bag(sys.argv[1]) as bag:
    count, last, ordered = 0, 0, True
    for raw in bag.raw_messages():
        ordered = ordered and raw.timestamp >= last
        count, last = count + 1, raw.timestamp
    print(json.dumps([count, ordered]))
"""


def _peak(path: Path) -> tuple[int, list[object]]:
    peak = peak_memory([sys.executable, '-c', READ, str(path)], timeout=600)
    assert peak.returncode == 0, peak.stderr
    return peak.anonymous, json.loads(peak.stdout)


@pytest.mark.skipif(not Path('/proc/self/status').exists(), reason='Linux /proc')
def test_a_longer_file_out_of_order_costs_no_more_memory_to_read(tmp_path: Path) -> None:
    small, _ = _shuffled_mcap(tmp_path / 'small.mcap', 50_000 // 3, size=100)
    large, _ = _shuffled_mcap(tmp_path / 'large.mcap', 250_000 // 3, size=100)
    small_peak, small_found = _peak(_cut_summary(small))
    large_peak, large_found = _peak(_cut_summary(large))
    assert (small_found, large_found) == ([50_000 // 3 * 3, True], [250_000 // 3 * 3, True])
    assert large_peak - small_peak < SLACK, (small_peak // MB, large_peak // MB)


# --- a last chunk cut short by the end of the file ---------------------------------------------


def _chunked_mcap(path: Path, compression: str, count: int = 4000) -> tuple[Messages, list[Chunk]]:
    """/a's ``count`` distinct messages, in time order, in 256 KiB chunks compressed with
    ``compression`` ('', 'lz4', 'zstd'): the messages and the chunks (index entries, in file
    order) as written."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    kind = {'': CompressionType.NONE, 'lz4': CompressionType.LZ4, 'zstd': CompressionType.ZSTD}
    written: Messages = []
    with path.open('wb') as stream:
        writer = Writer(stream, chunk_size=1 << 18, compression=kind[compression])
        writer.start(profile='ros2', library='zros tests')
        schema = writer.register_schema('std_msgs/msg/String', 'ros2msg', b'string data\n')
        channel = writer.register_channel('/a', 'cdr', schema)
        for index in range(count):
            text = hashlib.sha512(str(index).encode()).hexdigest().encode() * 2
            data = struct.pack('<II', 0x100, len(text) + 1) + text + b'\0'
            writer.add_message(channel, log_time=1000 + index, data=data, publish_time=index)
            written.append(('/a', 1000 + index, data))
        writer.finish()
    with path.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    return written, sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)


def _cut(path: Path, at: int) -> Path:
    """The file cut at byte ``at`` (as a copy of a file still being written)."""
    with path.open('r+b') as stream:
        stream.truncate(at)
    return path


def _to_cut(tmp_path: Path, compression: str) -> tuple[Path, Messages, Chunk, int]:
    """A file of :func:`_chunked_mcap` to cut: it, its messages, the full chunk a cut goes
    into (the one before the last) and how many messages lie before that chunk."""
    path = tmp_path / 'cut.mcap'
    truth, chunks = _chunked_mcap(path, compression)
    assert len(chunks) >= 3
    last = chunks[-2]
    return path, truth, last, sum(1 for m in truth if m[1] < last.message_start_time)


def _cut_into(path: Path, chunk: Chunk, fraction: float) -> int:
    """The file cut at ``fraction`` of ``chunk``: where it ends now."""
    end = chunk.chunk_start_offset + int(chunk.chunk_length * fraction)
    _cut(path, end)
    return end


def _records_at(chunk: Chunk) -> int:
    """Where an uncompressed chunk's records start (after its header and records length)."""
    return chunk.chunk_start_offset + 1 + 8 + 8 + 8 + 8 + 4 + 4 + len(chunk.compression) + 8


def _stopped_at(path: Path) -> str:
    recovered = RecoveredMcap(path)
    recovered.open()
    return recovered.stopped_at


@pytest.mark.parametrize('compression', ['', 'lz4', 'zstd'])
def test_a_last_chunk_cut_short_keeps_its_whole_messages(
    tmp_path: Path, compression: str, caplog: pytest.LogCaptureFixture
) -> None:
    path, truth, last, before = _to_cut(tmp_path, compression)
    in_chunk = [m for m in truth if last.message_start_time <= m[1] <= last.message_end_time]
    end = _cut_into(path, last, 0.5)
    with caplog.at_level(logging.WARNING, 'zros.bag'), Bag(path) as bag:
        got = [(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()]
        assert bag.message_count == len(got) and not bag.skipped
    # every message of the complete chunks, then an in-order part of the cut one, as written
    assert got == truth[: len(got)]
    kept = len(got) - before
    assert 0 < kept < len(in_chunk)
    said = (
        f'the file ends at byte {end}, inside the chunk at byte {last.chunk_start_offset} '
        f'({end - last.chunk_start_offset} of its {last.chunk_length} bytes present): its '
        f'first {kept} messages were read, the rest of it is lost'
    )
    assert _stopped_at(path) == said
    assert said in caplog.text


def test_a_cut_at_a_record_boundary_keeps_every_record_before_it(tmp_path: Path) -> None:
    path, truth, last, before = _to_cut(tmp_path, '')
    # the 10th message record of the (uncompressed) chunk ends where its 11th starts
    boundary = _records_at(last)
    with path.open('rb') as stream:
        for _ in range(10):
            stream.seek(boundary)
            opcode, length = struct.unpack('<BQ', stream.read(9))
            assert opcode == 0x05  # a message
            boundary += 9 + length
    assert _read(_cut(path, boundary)) == truth[: before + 10]
    assert 'its first 10 messages were read' in _stopped_at(path)
    assert _read(_cut(path, boundary - 1)) == truth[: before + 9]  # the 10th cut short
    assert 'its first 9 messages were read' in _stopped_at(path)


@pytest.mark.parametrize('into', [1, 9, 30, 'records length', 'records'])
def test_a_cut_inside_a_chunk_header_loses_only_that_chunk(tmp_path: Path, into: int | str) -> None:
    path, truth, last, before = _to_cut(tmp_path, 'zstd')
    start = last.chunk_start_offset
    records = _records_at(last)
    end = {'records length': records - 1, 'records': records}.get(str(into), start)
    end = end if isinstance(into, str) else start + into
    assert _read(_cut(path, end)) == truth[:before]
    if into == 'records':  # the header whole, no byte of its records
        assert _stopped_at(path) == (
            f'the file ends at byte {end}, inside the chunk at byte {start} ({end - start} of '
            f'its {last.chunk_length} bytes present): no whole message in the part present, '
            'that chunk is lost'
        )
    else:
        assert _stopped_at(path) == (
            f'the file ends at byte {end}, inside the header of the chunk at byte {start}: '
            'that chunk is lost'
        )


def test_reindex_keeps_the_whole_messages_of_a_cut_last_chunk(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    path, truth, last, before = _to_cut(tmp_path, 'zstd')
    end = _cut_into(path, last, 0.75)
    read = _read(path)
    kept = len(read) - before
    assert kept > 0
    report = reindex(path)
    assert report.message_count == len(read)
    assert str(report).startswith(
        f'cut.mcap: rewritten, {len(read)} messages up to its last whole message (the '
        f'{end - last.chunk_start_offset} bytes after its last complete chunk: the file ends at '
        f'byte {end}, inside the chunk at byte {last.chunk_start_offset} ('
    )
    assert str(report).endswith(
        f'its first {kept} messages were read, the rest of it is lost)\n'
        '  the original is kept as cut.orig.mcap'
    )
    with path.open('rb') as stream:  # finished: the mcap library's own reader reads it
        rewritten = [
            (c.topic, m.log_time, m.data) for _, c, m in make_reader(stream).iter_messages()
        ]
    assert rewritten == read == truth[: len(read)]


def test_a_cut_last_chunk_of_a_file_out_of_time_order_is_merged_in_time_order(
    tmp_path: Path,
) -> None:
    from mcap.reader import make_reader

    path, truth = _shuffled_mcap(tmp_path / 'shuffled.mcap', 3000, size=100, chunk_size=1 << 18)
    with path.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    last = max(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    before = tmp_path / 'before.mcap'  # the complete chunks
    before.write_bytes(path.read_bytes()[: last.chunk_start_offset])
    _cut_into(path, last, 0.75)
    recovered = RecoveredMcap(path)
    recovered.open()
    assert not recovered.in_order and 'messages were read' in recovered.stopped_at
    got = _read(path)
    # in time order, each as written, and more than the complete chunks hold
    assert got == sorted(got, key=lambda m: m[1]) and not Counter(got) - Counter(truth)
    assert len(got) > len(_read(before))


def test_a_real_recording_cut_at_60_percent_keeps_the_part_of_its_chunk(
    testdata: Path, tmp_path: Path
) -> None:
    original = testdata / 'ros2' / 'tf_nav2_mcap' / 'nav2_turtlebot.mcap'  # one zstd chunk
    whole = _read(original)
    path = tmp_path / original.name
    path.write_bytes(original.read_bytes()[: original.stat().st_size * 6 // 10])
    # it used to be an error: no complete record, not even the first chunk
    got = _read(path)
    assert len(got) > len(whole) // 2
    assert not Counter(got) - Counter(whole)  # each as recorded
    assert 'messages were read, the rest of it is lost' in _stopped_at(path)


# --- what stops the read of a cut chunk, and the other records the file's end cuts ------------


def _uncompressed_cut(tmp_path: Path) -> tuple[Path, Messages, Chunk, int, int]:
    """A file cut in the middle of its last (uncompressed) chunk present: it, the messages
    written, the chunk, how many messages lie before it and the offset of its 5th message."""
    path, truth, last, before = _to_cut(tmp_path, '')
    _cut_into(path, last, 0.5)
    fifth = _records_at(last)
    with path.open('rb') as stream:
        for _ in range(4):
            stream.seek(fifth)
            _, length = struct.unpack('<BQ', stream.read(9))
            fifth += 9 + length
    return path, truth, last, before, fifth


def _patch(path: Path, at: int, data: bytes) -> None:
    with path.open('r+b') as stream:
        stream.seek(at)
        stream.write(data)


@pytest.mark.parametrize(
    ('damage', 'reason'),
    [
        ('time', 'a message in it is not one its header declares'),
        ('length', 'a record in it is longer than the chunk'),
        ('schema', 'a record in it does not parse: '),
    ],
)
def test_a_damaged_record_stops_the_read_of_a_cut_chunk(
    tmp_path: Path, damage: str, reason: str
) -> None:
    path, truth, last, before, fifth = _uncompressed_cut(tmp_path)
    if damage == 'time':  # the 5th message's log time (after its channel id and sequence)
        _patch(path, fifth + 9 + 2 + 4, struct.pack('<Q', last.message_end_time + 1))
    elif damage == 'length':  # the 5th record's length
        _patch(path, fifth + 1, struct.pack('<Q', last.uncompressed_size))
    else:  # the 5th record made a schema whose name (from its sequence bytes on) is no UTF-8
        _patch(path, fifth, b'\x03')
        _patch(path, fifth + 9 + 2, struct.pack('<I', 4) + b'\xff\xfe\xfd\xfc')
    assert _read(path) == truth[: before + 4]
    assert f'its first 4 messages were read, the rest of it is lost ({reason}' in _stopped_at(path)


def test_more_data_than_the_cut_chunks_header_declares_stops_its_read(tmp_path: Path) -> None:
    path, truth, last, before, _ = _uncompressed_cut(tmp_path)
    # its uncompressed size (after opcode, length, start and end times): 1 byte
    _patch(path, last.chunk_start_offset + 1 + 8 + 8 + 8, struct.pack('<Q', 1))
    assert _read(path) == truth[:before]
    assert _stopped_at(path).endswith(
        'no whole message in the part present, that chunk is lost '
        '(it decompresses to more than its header declares)'
    )


def test_a_cut_chunk_that_stops_decompressing_keeps_what_came_before(tmp_path: Path) -> None:
    path, truth, last, before = _to_cut(tmp_path, 'lz4')
    end = _cut_into(path, last, 0.75)
    whole = _read(path)
    # garbage in its last quarter present: what decompresses before it is kept
    _patch(path, end - last.chunk_length // 4, bytes(range(256)) * 16)
    got = _read(path)
    assert before <= len(got) < len(whole) and got == truth[: len(got)]
    assert '(it does not decompress further: ' in _stopped_at(path)


def test_a_record_outside_chunks_cut_short_is_named(tmp_path: Path) -> None:
    from mcap.records import Message

    path = make_points_mcap(tmp_path / 'loose.mcap', 100, chunked=False, shuffle=False)
    scan = LinearScan(path)
    units = [scan.unit for record in scan.records() if isinstance(record, Message)]
    start, end = units[-1]
    _cut(path, start + 20)  # inside its last message
    recovered = RecoveredMcap(path)
    recovered.open()
    assert recovered.metadata is not None and recovered.metadata.message_count == 99
    assert recovered.stopped_at == (
        f'the file ends at byte {start + 20}, inside the message record at byte {start} '
        f'(20 of its {end - start} bytes present)'
    )


def test_a_chunk_whose_length_runs_past_the_end_in_the_middle_is_skipped(
    tmp_path: Path,
) -> None:
    path = tmp_path / 'long.mcap'
    truth, chunks = _chunked_mcap(path, 'zstd')
    _cut_summary(path)
    middle = chunks[1]
    _patch(path, middle.chunk_start_offset + 1, struct.pack('<Q', 1 << 40))
    with Bag(path) as bag:
        got = [(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()]
        [skipped] = bag.skipped
    assert got == [
        m for m in truth if not middle.message_start_time <= m[1] <= middle.message_end_time
    ]
    assert skipped.reason.startswith(
        f'the chunk record at byte {middle.chunk_start_offset} declares {1 << 40} bytes, past '
        "the file's end at byte "
    )
