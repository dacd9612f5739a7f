"""The Foxglove bag server's memory against the bag's size (``zros foxglove --bag``).

Writes the bag ``benchmarks/bag.py`` writes (Imu, LaserScan and Odometry, a third each, with
rosbags' writer) at each ``--count``, serves it with ``BagGateway`` in a process of its own,
and has a real Foxglove client (``@foxglove/ws-protocol`` under tests/gateway/node) subscribe
to every channel and play the whole bag as fast as the server sends, then again from its middle
(a seek). Prints the server
process's memory once listening (idle) and its peaks while playing (``/proc/PID/status``
sampled every millisecond), the peak anonymous memory of its child (the front process that
relays the WebSocket bytes) and of both together, beside the bag's size. Goal: peak anonymous memory at most 256 MB
above idle, whatever the bag's size.

    python benchmarks/bag_server.py                          # 100,000 and 1,000,000 messages
    python benchmarks/bag_server.py --count 100000 --count 1000000 --count 3000000
    python benchmarks/bag_server.py --storage sqlite3
    python benchmarks/bag_server.py --storage ros1            # Imu messages only
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent)]

from bag import BOUND_MB, TYPES, write_bag  # noqa: E402

from tests.gateway.foxglove.bag_memory import play_through  # noqa: E402
from tests.gateway.node_process import install  # noqa: E402


def write_ros1(path: Path, count: int) -> Path:
    """A ROS 1 bag of ``count`` Imu messages on /imu, 1 ms apart, written by rosbags."""
    import numpy as np
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    imu = 'sensor_msgs/msg/Imu'
    vector = T['geometry_msgs/msg/Vector3'](1.0, 2.0, 3.0)
    with Writer(path) as writer:
        connection = writer.add_connection('/imu', imu, typestore=store)
        for index in range(count):
            stamp = T['builtin_interfaces/msg/Time'](sec=index // 1000, nanosec=index % 1000)
            message = T[imu](
                T['std_msgs/msg/Header'](seq=index, stamp=stamp, frame_id='imu'),
                T['geometry_msgs/msg/Quaternion'](0.0, 0.0, 0.0, 1.0),
                np.zeros(9),
                vector,
                np.zeros(9),
                vector,
                np.zeros(9),
            )
            writer.write(connection, 10**9 + index * 10**6, store.serialize_ros1(message, imu))
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--count', type=int, action='append', help='messages in a bag (repeatable)')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3', 'ros1'), default='mcap')
    args = parser.parse_args()
    counts = args.count or [100_000, 1_000_000]
    reason = install()
    if reason is not None:
        raise SystemExit(reason)
    rows = []
    for count in counts:
        with tempfile.TemporaryDirectory() as folder:
            begin = time.perf_counter()
            if args.storage == 'ros1':
                path = write_ros1(Path(folder) / 'sensors.bag', count)
                size = path.stat().st_size / 1e6
            else:
                path = Path(folder) / 'sensors'
                write_bag(path, count, args.storage)
                size = sum(f.stat().st_size for f in path.iterdir()) / 1e6
            seconds = time.perf_counter() - begin
            print(
                f'bag: {count} messages ({args.storage}, {size:.0f} MB), written in {seconds:.0f} s'
            )
            topics = ['/imu'] if args.storage == 'ros1' else list(TYPES)
            # both writers put message i at 1 s + i ms
            middle = (10**9 + count // 2 * 10**6, count - count // 2)
            played = play_through(path, topics, timeout=3600, seeks=[middle])
        assert played.published == count + middle[1], (played.published, count)
        rows.append((count, size, played))
    print()
    print(
        '| messages | bag MB | idle anonymous MB | peak anonymous MB | above idle MB '
        '| peak file-mapped MB | front peak anonymous MB | server + front peak anonymous MB '
        '| seconds | messages/s | sent | received by the client |'
    )
    print('|---|---|---|---|---|---|---|---|---|---|---|---|')
    worst = 0.0
    for count, size, played in rows:
        idle, peak = played.idle_anonymous / 1e6, played.peak.anonymous / 1e6
        worst = max(worst, peak - idle)
        print(
            f'| {count} | {size:.0f} | {idle:.0f} | {peak:.0f} | {peak - idle:.0f} '
            f'| {played.peak.file / 1e6:.0f} | {played.peak.children_anonymous / 1e6:.0f} '
            f'| {played.peak.total_anonymous / 1e6:.0f} | {played.seconds:.1f} '
            f'| {played.published / played.seconds:.0f} | {played.published} | {played.received} |'
        )
    verdict = 'met' if worst <= BOUND_MB else 'NOT met'
    print(f'peak anonymous above idle: {worst:.0f} MB at most (goal <= {BOUND_MB} MB: {verdict})')


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()
