"""An MCAP file without summary whose chunks are out of time order is read in time order, a
chunk at a time: memory does not grow with the recording, and a damaged chunk costs only its
own messages."""

from __future__ import annotations

import json
import logging
import struct
import sys
from pathlib import Path

import pytest

from tests.bag.makebags import make_points_mcap
from tests.bag.read.test_damage import zero_a_chunk
from zros.bag import Bag
from zros.bag.read.mcap_recover import RecoveredMcap
from zros.testing import peak_memory

Messages = list[tuple[str, int, bytes]]
MB = 1 << 20
#: what the peak may grow by from 50,000 messages to 250,000 (held whole and sorted, the
#: 200,000 more took about 50 MB)
SLACK = 8 * MB


def _shuffled_mcap(path: Path, count: int, size: int = 16) -> tuple[Path, Messages]:
    """Three topics written one after the other in 4 KB zstd chunks, so chunks overlap in
    time and later chunks start earlier: /a every 10 ns, /b at the same times as /a (ties
    across chunks), /c going back in time in pairs of equal times (ties inside a chunk). The
    messages in the order a reader must give them: time, then file order."""
    from mcap.writer import CompressionType, Writer

    written: list[tuple[int, int, str, bytes]] = []
    with path.open('wb') as stream:
        writer = Writer(stream, chunk_size=1 << 12, compression=CompressionType.ZSTD)
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
