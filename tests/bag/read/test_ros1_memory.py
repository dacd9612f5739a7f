"""Opening a longer ROS 1 bag costs no more memory than a short one, whole or cut short.

rosbags' reader kept the index entry of every message from the moment it opened a bag (about
165 bytes each), and a bag cut short (its index gone) was read into memory whole; zros reads a
chunk's index, or a cut bag's chunk, when a read reaches it. Each read runs in a process of its
own, whose peak anonymous memory ``zros.testing.peak_memory`` samples.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from zros.testing import peak_memory

pytestmark = pytest.mark.skipif(not Path('/proc/self/status').exists(), reason='Linux /proc')

MB = 1 << 20
#: what the peak may grow by from a bag of 50,000 messages to one of 250,000 (the index of
#: the 200,000 more took 30 MB; cut short, their payloads 26 MB)
SLACK = 8 * MB

#: open the bag, read 1,000 messages from its middle and its last one
READ = """
import json, sys
from zros.bag import Bag
with Bag(sys.argv[1]) as bag:
    middle = (bag.start_ns + bag.end_ns) // 2
    found = sum(1 for _ in bag.raw_messages(start=middle, end=middle + 1000 * 1000))
    last = list(bag.raw_messages(start=bag.end_ns))
    print(json.dumps([bag.message_count, found, len(last)]))
"""


def _bag(path: Path, count: int) -> Path:
    """A ROS 1 bag of ``count`` small messages on /count, 1 µs apart, written by rosbags."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    kind = 'std_msgs/msg/UInt32'
    with Writer(path) as writer:
        connection = writer.add_connection('/count', kind, typestore=store)
        for index in range(count):
            writer.write(connection, 1000 * (index + 1), index.to_bytes(4, 'little'))
    return path


def _read(path: Path) -> tuple[int, list[int]]:
    peak = peak_memory([sys.executable, '-c', READ, str(path)], timeout=300)
    assert peak.returncode == 0, peak.stderr
    return peak.anonymous, json.loads(peak.stdout)


def _cut(path: Path) -> Path:
    """The bag cut at 90 %: its index at the end is gone."""
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 9 // 10])
    return path


@pytest.mark.parametrize('cut', [False, True], ids=['indexed', 'cut short'])
def test_a_longer_ros1_bag_costs_no_more_memory_to_open_and_seek(tmp_path: Path, cut: bool) -> None:
    small, large = _bag(tmp_path / 'small.bag', 50_000), _bag(tmp_path / 'large.bag', 250_000)
    if cut:
        small, large = _cut(small), _cut(large)
    small_peak, small_found = _read(small)
    large_peak, large_found = _read(large)
    if not cut:
        assert (small_found[0], large_found[0]) == (50_000, 250_000)
    assert small_found[1:] == large_found[1:] == [1000, 1]
    assert large_peak - small_peak < SLACK, (small_peak // MB, large_peak // MB)
