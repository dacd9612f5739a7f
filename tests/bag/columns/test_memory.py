"""Reading a larger recording costs the larger answer, not a multiple of the recording.

Each read runs in a process of its own, whose peak anonymous memory ``zros.testing.peak_memory``
samples; the same query on a bag four times larger may cost its larger output and little more.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from zros.cdr import encode, new_message
from zros.testing import peak_memory

pytestmark = pytest.mark.skipif(not Path('/proc/self/status').exists(), reason='Linux /proc')

MB = 1 << 20
#: floats per scan: 8 KB of ranges, so a bag of 8,000 scans returns 64 MB of them
RANGES = 2000
#: what anonymous memory beyond the output may grow by when the bag grows four times
SLACK = 32 * MB

#: batches of 1,000 messages here stand for the 65,536 of a recording 65 times larger
READ = """
import json, sys
from zros.bag import Bag
from zros.bag.columns import extract
extract.BATCH = 1000
with Bag(sys.argv[1]) as bag:
    if sys.argv[2] == 'columns':
        found = bag.columns('/scan', ['ranges', 'angle_max'])
        output = sum(column.nbytes for column in found.values())
    elif sys.argv[2] == 'frame':
        found = bag.to_dataframe('/scan', ['ranges', 'angle_max'])
        output = int(found.memory_usage().sum())
    elif sys.argv[2] == 'point':
        # 65,536 points a batch, as in any recording, and 4 MiB of chunks for 64
        extract.BATCH, extract.BATCH_BYTES = 65536, 4 << 20
        found = bag.columns('/point', ['x'])
        output = sum(column.nbytes for column in found.values())
    else:
        output = sum(1 for _ in bag)
print(json.dumps(output))
"""


def _scans(path: Path, count: int) -> Path:
    """A rosbag2 MCAP bag of ``count`` LaserScans on /scan, written by rosbags."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    scan = new_message('sensor_msgs/msg/LaserScan', ranges=np.arange(RANGES, dtype=np.float32))
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection('/scan', 'sensor_msgs/msg/LaserScan', typestore=store)
        for index in range(count):
            scan.angle_max = float(index)
            writer.write(conn, 1_000_000 * (index + 1), encode(scan))
    return path


def _mixed(path: Path, count: int) -> Path:
    """A bag written by zros (chunks compressed with zstd) of ``count`` LaserScans on /scan and
    as many Points on /point, one after the other."""
    from zros.bag.write.bag_writer import BagTopic, BagWriter
    from zros.cdr import default_registry

    scan = new_message('sensor_msgs/msg/LaserScan', ranges=np.arange(RANGES, dtype=np.float32))
    with BagWriter(path) as writer:
        scans, points = (
            writer.add_topic(BagTopic.from_registry(default_registry(), name, type_name))
            for name, type_name in (
                ('/scan', 'sensor_msgs/msg/LaserScan'),
                ('/point', 'geometry_msgs/msg/Point'),
            )
        )
        for index in range(count):
            stamp = 1_000_000 * (index + 1)
            writer.write(scans, stamp, encode(scan))
            writer.write(points, stamp, encode(new_message('geometry_msgs/msg/Point', x=index)))
    return path


def _read(path: Path, how: str) -> tuple[int, int]:
    """Peak anonymous memory of a process reading ``path`` ``how``, and its output bytes."""
    peak = peak_memory([sys.executable, '-c', READ, str(path), how], timeout=300)
    assert peak.returncode == 0, peak.stderr
    return peak.anonymous, json.loads(peak.stdout)


@pytest.fixture(scope='module')
def bags(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    folder = tmp_path_factory.mktemp('memory')
    return _scans(folder / 'small', 2000), _scans(folder / 'large', 8000)


def test_columns_cost_their_output_not_the_recording(bags: tuple[Path, Path]) -> None:
    small, large = bags
    small_peak, small_output = _read(small, 'columns')
    large_peak, large_output = _read(large, 'columns')
    assert large_output > 64_000_000  # the ranges (and angle_max, time) of 8,000 scans
    # joined per-batch arrays, then reordered, held the ranges three times: +96 MB here
    assert (large_peak - large_output) - (small_peak - small_output) < SLACK, (
        small_peak // MB,
        large_peak // MB,
    )


def test_a_dataframe_costs_its_output(bags: tuple[Path, Path]) -> None:
    pytest.importorskip('pandas')
    small, large = bags
    small_peak, small_output = _read(small, 'frame')
    large_peak, large_output = _read(large, 'frame')
    assert large_output > 64_000_000
    # pandas' default copy of the columns held them twice: +48 MB here
    assert (large_peak - large_output) - (small_peak - small_output) < SLACK, (
        small_peak // MB,
        large_peak // MB,
    )


def test_a_small_topic_does_not_keep_the_chunks_it_shares_alive(tmp_path: Path) -> None:
    small, large = _mixed(tmp_path / 'small', 2000), _mixed(tmp_path / 'large', 8000)
    small_peak, small_output = _read(small, 'point')
    large_peak, large_output = _read(large, 'point')
    assert (small_output, large_output) == (2000 * 16, 8000 * 16)
    # counting only its payloads kept every decompressed chunk of a batch: +48 MB here
    assert large_peak - small_peak < SLACK, (small_peak // MB, large_peak // MB)


def test_the_message_loop_holds_a_chunk_at_a_time(bags: tuple[Path, Path]) -> None:
    small, large = bags
    small_peak, small_count = _read(small, 'loop')
    large_peak, large_count = _read(large, 'loop')
    assert (small_count, large_count) == (2000, 8000)
    assert large_peak - small_peak < SLACK, (small_peak // MB, large_peak // MB)
