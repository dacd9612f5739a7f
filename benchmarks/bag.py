"""Bag reading: zros ``Bag.columns`` and ``for msg in bag`` against rosbags, same bag, same
process.

Writes a rosbag2 bag of sensor_msgs/Imu, sensor_msgs/LaserScan and nav_msgs/Odometry (a third
each) with rosbags' writer into a temporary folder, then

- pulls the same numeric fields into numpy arrays two ways (goal: zros >= 8x faster than a
  rosbags loop on MCAP), and
- decodes every message into a typed message two ways, ``for topic, time, msg in bag`` against
  rosbags' AnyReader + deserialize_cdr (goal: zros >= 2x faster),
- puts /odom's and /scan's fields on /imu's clock two ways, ``Bag.align`` against a rosbags
  loop into pandas DataFrames and ``merge_asof`` (goal: zros >= 5x faster; needs pandas),

and prints the seconds (the median of ``--repeat`` runs), the ratios and, each reader running
in a process of its own, its peak anonymous and file-mapped memory (``/proc/PID/status``
sampled every millisecond; goal for ``Bag.columns``: its arrays plus 256 MB at most).

    python benchmarks/bag.py                  # 100,000 messages, mcap
    python benchmarks/bag.py --count 1000000  # 1.38 GB
    python benchmarks/bag.py --count 20000 --storage sqlite3
    python benchmarks/bag.py --scale          # a 10 GB bag, zros alone (needs 10 GB of disk)
"""

from __future__ import annotations

import argparse
import hashlib
import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from zros.bag import Bag
from zros.testing import peak_memory

FIELDS = {
    '/imu': [
        'orientation.x',
        'orientation.y',
        'orientation.z',
        'orientation.w',
        'angular_velocity.z',
        'linear_acceleration.x',
        'linear_acceleration.y',
        'linear_acceleration.z',
    ],
    '/scan': ['header.stamp.sec', 'angle_min', 'angle_increment', 'ranges'],
    '/odom': [
        'pose.pose.position.x',
        'pose.pose.position.y',
        'pose.pose.orientation.z',
        'pose.pose.orientation.w',
        'twist.twist.linear.x',
        'twist.twist.angular.z',
    ],
}
TYPES = {
    '/imu': 'sensor_msgs/msg/Imu',
    '/scan': 'sensor_msgs/msg/LaserScan',
    '/odom': 'nav_msgs/msg/Odometry',
}
SCAN_SIZE = 360
#: the size of the ``--scale`` bag, and how many bytes a message of this bag takes on average
SCALE_BYTES = 10_000_000_000
MESSAGE_BYTES = 1377
#: peak anonymous memory allowed beyond the arrays ``Bag.columns`` returns
BOUND_MB = 256


def write_bag(path: Path, count: int, storage: str) -> None:
    """``count`` messages, cycling Imu, LaserScan, Odometry, 1 ms apart."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    T = store.types
    rng = np.random.default_rng(1)
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3

    def header(index: int, frame: str) -> Any:
        stamp = T['builtin_interfaces/msg/Time'](sec=index // 1000, nanosec=index % 1000)
        return T['std_msgs/msg/Header'](stamp=stamp, frame_id=frame)

    def vector(v: np.ndarray) -> Any:
        return T['geometry_msgs/msg/Vector3'](*v)

    def quaternion(v: np.ndarray) -> Any:
        return T['geometry_msgs/msg/Quaternion'](*v)

    with Writer(path, version=9, storage_plugin=plugin) as writer:
        connections = {
            topic: writer.add_connection(topic, type_name, typestore=store)
            for topic, type_name in TYPES.items()
        }
        topics = list(TYPES)
        for index in range(count):
            topic = topics[index % 3]
            v = rng.random(16)
            message: Any
            if topic == '/imu':
                message = T[TYPES[topic]](
                    header(index, 'imu_link'),
                    quaternion(v[:4]),
                    rng.random(9),
                    vector(v[4:7]),
                    rng.random(9),
                    vector(v[7:10]),
                    rng.random(9),
                )
            elif topic == '/scan':
                message = T[TYPES[topic]](
                    header(index, 'laser'),
                    -3.1,
                    3.1,
                    6.2 / SCAN_SIZE,
                    0.0,
                    0.1,
                    0.1,
                    30.0,
                    rng.random(SCAN_SIZE).astype(np.float32),
                    rng.random(SCAN_SIZE).astype(np.float32),
                )
            else:
                pose = T['geometry_msgs/msg/Pose'](
                    T['geometry_msgs/msg/Point'](*v[:3]), quaternion(v[3:7])
                )
                twist = T['geometry_msgs/msg/Twist'](vector(v[7:10]), vector(v[10:13]))
                message = T[TYPES[topic]](
                    header(index, 'odom'),
                    'base_link',
                    T['geometry_msgs/msg/PoseWithCovariance'](pose, rng.random(36)),
                    T['geometry_msgs/msg/TwistWithCovariance'](twist, rng.random(36)),
                )
            data = store.serialize_cdr(message, TYPES[topic])
            writer.write(connections[topic], 1_000_000_000 + index * 1_000_000, data)


def _pick(message: Any, path: str) -> Any:
    for part in path.split('.'):
        message = getattr(message, part)
    return message


def with_rosbags(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """The plain way: AnyReader, deserialize_cdr per message, fields into lists, then numpy."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    values: dict[str, dict[str, list[Any]]] = {
        topic: {name: [] for name in ['time', *fields]} for topic, fields in FIELDS.items()
    }
    with AnyReader([path], default_typestore=store) as reader:
        for connection, stamp, data in reader.messages():
            message = reader.typestore.deserialize_cdr(data, connection.msgtype)
            columns = values[connection.topic]
            columns['time'].append(stamp)
            for name in FIELDS[connection.topic]:
                columns[name].append(_pick(message, name))
    return {
        topic: {name: np.asarray(column) for name, column in columns.items()}
        for topic, columns in values.items()
    }


def with_zros(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """``Bag.columns`` per topic."""
    with Bag(path) as bag:
        return {topic: bag.columns(topic, fields) for topic, fields in FIELDS.items()}


def loop_rosbags(path: Path) -> int:
    """Every message decoded into rosbags' typed message, in time order."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    count = 0
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        deserialize = reader.typestore.deserialize_cdr
        for connection, _stamp, data in reader.messages():
            deserialize(data, connection.msgtype)
            count += 1
    return count


def loop_zros(path: Path) -> int:
    """Every message decoded into a zros message, in time order: ``for msg in bag``."""
    count = 0
    with Bag(path) as bag:
        for _topic, _stamp, _message in bag:
            count += 1
    return count


# --- align: topics on one clock -------------------------------------------------------------

#: the fields put on /imu's clock (header stamps, nearest within ALIGN_TOLERANCE)
ALIGN = {
    '/imu': ['linear_acceleration.x', 'linear_acceleration.y', 'angular_velocity.z'],
    '/odom': ['pose.pose.position.x', 'pose.pose.position.y', 'twist.twist.linear.x'],
    '/scan': ['angle_min', 'range_max'],
}
ALIGN_TOLERANCE = 2e-9  # the bag's stamps are index // 1000 s + index % 1000 ns


def align_pandas(path: Path) -> Any:
    """The way users do it today: rosbags loop -> a DataFrame per topic -> merge_asof."""
    import pandas as pd
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    rows: dict[str, dict[str, list[Any]]] = {
        topic: {name: [] for name in ['time', *fields]} for topic, fields in ALIGN.items()
    }
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        for connection, _stamp, data in reader.messages():
            message = reader.typestore.deserialize_cdr(data, connection.msgtype)
            columns = rows[connection.topic]
            stamp = message.header.stamp
            columns['time'].append(stamp.sec * 1_000_000_000 + stamp.nanosec)
            for name in ALIGN[connection.topic]:
                columns[name].append(_pick(message, name))
    frames = {
        topic: pd.DataFrame(
            {name if name == 'time' else f'{topic}.{name}': values for name, values in cols.items()}
        ).sort_values('time', kind='stable')
        for topic, cols in rows.items()
    }
    table = frames['/imu']
    for topic in ('/odom', '/scan'):
        table = pd.merge_asof(
            table,
            frames[topic],
            on='time',
            direction='nearest',
            tolerance=round(ALIGN_TOLERANCE * 1e9),
        )
    return table


def align_zros(path: Path) -> Any:
    """``Bag.align`` from the file."""
    with Bag(path) as bag:
        return bag.align(ALIGN, on='/imu', method='nearest', tolerance=ALIGN_TOLERANCE)


def align_report(path: Path, repeat: int) -> list[str]:
    """Time both ways of aligning and check they agree; the lines to print."""
    try:
        import pandas  # noqa: F401
    except ImportError:
        return ['align: pandas is not installed, no merge_asof to compare with']
    theirs_time, theirs = median(align_pandas, path, repeat)
    mine_time, mine = median(align_zros, path, repeat)
    assert list(theirs.columns) == list(mine.dtype.names), (theirs.columns, mine.dtype.names)
    for name in mine.dtype.names:
        assert np.array_equal(mine[name], theirs[name].to_numpy(), equal_nan=True), name
    ratio = theirs_time / mine_time
    verdict = 'met' if ratio >= 5 else 'NOT met'
    return [
        '',
        '| align /odom and /scan on /imu (nearest, from the file) | seconds |',
        '|---|---|',
        f'| rosbags loop + pandas merge_asof | {theirs_time:.3f} |',
        f'| zros Bag.align | {mine_time:.3f} |',
        f'align: zros is {ratio:.1f}x faster than rosbags + merge_asof (goal >= 5x: {verdict})',
    ]


def median(function: Callable[[Path], Any], path: Path, repeat: int) -> tuple[float, Any]:
    """The median seconds of ``repeat`` runs, and the last result (the one before dropped
    before each run, so the peak memory is that of one run)."""
    times = []
    result = None
    for _ in range(repeat):
        result = None
        begin = time.perf_counter()
        result = function(path)
        times.append(time.perf_counter() - begin)
    return statistics.median(times), result


#: name -> (function, what the table calls it); the names say columns or loop
READERS: dict[str, tuple[Callable[[Path], Any], str]] = {
    'columns_rosbags': (with_rosbags, 'columns: rosbags AnyReader + deserialize_cdr, fields into lists'),
    'columns_zros': (with_zros, 'columns: zros Bag.columns'),
    'loop_rosbags': (loop_rosbags, 'typed loop: rosbags AnyReader + deserialize_cdr'),
    'loop_zros': (loop_zros, 'typed loop: zros for msg in bag'),
}  # fmt: skip


def _digest(result: Any) -> Any:
    """What two readers' results must agree on: the count, or a hash of every column."""
    if isinstance(result, int):
        return result
    digests = {}
    for topic, columns in result.items():
        for name, column in columns.items():
            values = np.asarray(column)
            kind = np.int64 if values.dtype.kind in 'iub' else np.float64
            digest = hashlib.sha256(repr(values.shape).encode())
            for at in range(0, len(values), 4096):  # a slice at a time: no copy of the column
                digest.update(np.ascontiguousarray(values[at : at + 4096], kind).data)
            digests[f'{topic} {name}'] = digest.hexdigest()
    return digests


def worker(name: str, path: Path, repeat: int) -> None:
    """Run one reader (in a process of its own) and print its seconds and result as JSON."""
    seconds, result = median(READERS[name][0], path, repeat)
    output = 0
    if not isinstance(result, int):
        output = sum(c.nbytes for columns in result.values() for c in columns.values())
    print(json.dumps({'seconds': seconds, 'check': _digest(result), 'output': output}))


def measure(name: str, path: Path, repeat: int) -> dict[str, Any]:
    """One reader in a process of its own: its seconds, result digest and memory peaks."""
    argv = [sys.executable, __file__, '--worker', name, str(path), '--repeat', str(repeat)]
    peak = peak_memory(argv, timeout=24 * 3600)
    if peak.returncode:
        raise SystemExit(f'{name} failed:\n{peak.stderr}')
    found: dict[str, Any] = json.loads(peak.stdout.splitlines()[-1])
    found.update(anonymous=peak.anonymous / 1e6, file=peak.file / 1e6)
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--count', type=int, default=100_000, help='messages in the bag')
    parser.add_argument('--storage', choices=('mcap', 'sqlite3'), default='mcap')
    parser.add_argument('--repeat', type=int, default=3, help='runs of each; the median counts')
    parser.add_argument(
        '--scale',
        action='store_true',
        help=f'write and read a {SCALE_BYTES / 1e9:.0f} GB bag with zros alone, once',
    )
    parser.add_argument('--worker', nargs=2, metavar=('READER', 'PATH'), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.worker[0], Path(args.worker[1]), args.repeat)
        return
    names = list(READERS)
    if args.scale:
        args.count, args.repeat = SCALE_BYTES // MESSAGE_BYTES, 1
        names = ['columns_zros', 'loop_zros']
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / 'sensors'
        begin = time.perf_counter()
        write_bag(path, args.count, args.storage)
        size = sum(f.stat().st_size for f in path.iterdir()) / 1e6
        print(
            f'bag: {args.count} messages ({args.storage}, {size:.1f} MB), '
            f'written in {time.perf_counter() - begin:.1f} s'
        )
        found = {name: measure(name, path, args.repeat) for name in names}
        aligned = [] if args.scale else align_report(path, args.repeat)
    for kind, want in (('columns', None), ('loop', args.count)):
        checks = [found[n]['check'] for n in names if n.startswith(kind)]
        assert all(c == checks[0] for c in checks), f'{kind}: the readers disagree'
        assert want is None or checks[0] == want, (checks[0], want)
    print()
    print('| reader | seconds | µs per message | peak anonymous MB | peak file-mapped MB |')
    print('|---|---|---|---|---|')
    for name in names:
        got = found[name]
        print(
            f'| {READERS[name][1]} | {got["seconds"]:.3f} | '
            f'{got["seconds"] / args.count * 1e6:.2f} | {got["anonymous"]:.0f} | {got["file"]:.0f} |'
        )
    output = found['columns_zros']['output'] / 1e6
    anonymous = found['columns_zros']['anonymous']
    verdict = 'met' if anonymous <= output + BOUND_MB else 'NOT met'
    print(
        f'zros columns: {output:.0f} MB of arrays, peak anonymous {anonymous:.0f} MB '
        f'(goal <= arrays + {BOUND_MB} MB: {verdict})'
    )
    if args.scale:
        return
    goal = 8 if args.storage == 'mcap' else 3
    for what, ratio, want in (
        ('columns', found['columns_rosbags']['seconds'] / found['columns_zros']['seconds'], goal),
        ('typed loop', found['loop_rosbags']['seconds'] / found['loop_zros']['seconds'], 2),
    ):
        verdict = 'met' if ratio >= want else 'NOT met'
        print(f'{what}: zros is {ratio:.1f}x faster than rosbags (goal >= {want}x: {verdict})')
    print('\n'.join(aligned))


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()
