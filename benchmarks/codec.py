"""CDR codec speed: zros against mcap-ros2-support-fast, rosbags, pycdr2 and rclpy, in one
process, same content.

Prints microseconds per message (each run takes the best of several repeats; with ``--runs N``
the median of N runs), a memcpy column (copying the encoded bytes once), a view column
(``cdr.decode(type_name, view)`` of a read-only memoryview slice of a bigger buffer, the way bag
chunks are read, with its ratio to decoding the bytes) and the goals as ratios.
zros decodes through its public API: ``cdr.decode(type_name, data)`` (``name``) and
``decode(cls, data)``, what a subscriber runs per message (``cls``).

    pip install -e '.[bench]'             # mcap-ros2-support-fast (GPL: benchmark-only)
    python benchmarks/codec.py            # all messages
    python benchmarks/codec.py --quick    # fewer repeats
    python benchmarks/codec.py --runs 3 --only Twist

A second table times building messages with keyword arguments (and one attribute assignment),
the loop a node runs before each ``write``: zros checks field names and value types there.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from collections.abc import Callable
from importlib import metadata
from typing import Any

import numpy as np

from zros import cdr
from zros.cdr.message import decode as decode_class
from zros.cdr.registry import TypeRegistry, set_default_registry

REGISTRY = TypeRegistry('jazzy', paths=[], ament=False)


def C(name: str) -> Any:  # noqa: N802
    return REGISTRY.get_class(name)


# --- the messages ------------------------------------------------------------------------


def _header(frame: str) -> Any:
    return C('std_msgs/msg/Header')(stamp={'sec': 1740933158, 'nanosec': 226629828}, frame_id=frame)


def build_messages() -> dict[str, Any]:
    """The benchmark messages in zros form; the other libraries get the same content."""
    rng = np.random.default_rng(7)
    Pose = C('geometry_msgs/msg/Pose')
    Point = C('geometry_msgs/msg/Point')
    messages: dict[str, Any] = {}
    messages['String'] = C('std_msgs/msg/String')(data='hello world, this is zros')
    messages['Twist'] = C('geometry_msgs/msg/Twist')(
        linear={'x': 0.5, 'y': 0.1}, angular={'z': 0.3}
    )
    messages['Imu'] = C('sensor_msgs/msg/Imu')(
        header=_header('imu_link'),
        orientation={'x': 0.1, 'y': 0.2, 'z': 0.3, 'w': 0.9},
        orientation_covariance=rng.random(9),
        angular_velocity={'x': 0.01, 'y': 0.02, 'z': 0.03},
        angular_velocity_covariance=rng.random(9),
        linear_acceleration={'x': 0.1, 'y': 0.2, 'z': 9.81},
        linear_acceleration_covariance=rng.random(9),
    )
    odom = C('nav_msgs/msg/Odometry')(header=_header('odom'), child_frame_id='base_link')
    odom.pose.pose.position.x = 1.0
    odom.pose.covariance = rng.random(36)
    odom.twist.twist.linear.x = 0.5
    odom.twist.covariance = rng.random(36)
    messages['Odometry'] = odom
    TransformStamped = C('geometry_msgs/msg/TransformStamped')
    messages['TFMessage(10)'] = C('tf2_msgs/msg/TFMessage')(
        transforms=[
            TransformStamped(
                header=_header('map'),
                child_frame_id=f'link_{i}',
                transform={'translation': {'x': float(i)}, 'rotation': {'w': 1.0}},
            )
            for i in range(10)
        ]
    )
    messages['LaserScan(720)'] = C('sensor_msgs/msg/LaserScan')(
        header=_header('laser'),
        angle_min=-3.14,
        angle_max=3.14,
        angle_increment=0.00873,
        range_max=30.0,
        ranges=rng.random(720).astype(np.float32) * 30,
        intensities=rng.random(720).astype(np.float32),
    )
    Image = C('sensor_msgs/msg/Image')
    for label, (width, height) in (
        ('Image 640x480', (640, 480)),
        ('Image 1920x1080', (1920, 1080)),
    ):
        messages[label] = Image(
            header=_header('camera'),
            height=height,
            width=width,
            encoding='rgb8',
            step=3 * width,
            data=rng.integers(0, 256, 3 * width * height, dtype=np.uint8),
        )
    PointField = C('sensor_msgs/msg/PointField')
    points = 100_000
    messages['PointCloud2(100k)'] = C('sensor_msgs/msg/PointCloud2')(
        header=_header('lidar'),
        height=1,
        width=points,
        fields=[PointField(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate('xyz')]
        + [PointField(name='intensity', offset=12, datatype=7, count=1)],
        point_step=16,
        row_step=16 * points,
        data=rng.integers(0, 256, 16 * points, dtype=np.uint8),
        is_dense=True,
    )
    table = np.zeros(1000, dtype=Pose._dtype)
    table['position']['x'] = np.arange(1000)
    table['orientation']['w'] = 1.0
    poses = C('geometry_msgs/msg/PoseArray')(header=_header('map'))
    poses.poses.array = table
    messages['PoseArray(1000)'] = poses
    messages['PoseArray(1000) objects'] = C('geometry_msgs/msg/PoseArray')(
        header=_header('map'),
        poses=[
            Pose(position=Point(float(i), 0.0, 0.0), orientation={'w': 1.0}) for i in range(1000)
        ],
    )
    Marker = C('visualization_msgs/msg/Marker')
    ColorRGBA = C('std_msgs/msg/ColorRGBA')
    messages['MarkerArray(100)'] = C('visualization_msgs/msg/MarkerArray')(
        markers=[
            Marker(
                header=_header('map'),
                ns='path',
                id=i,
                type=4,
                pose={'position': {'x': float(i)}, 'orientation': {'w': 1.0}},
                scale={'x': 0.05},
                color={'r': 1.0, 'a': 1.0},
                points=[Point(float(k), 0.0, 0.0) for k in range(4)],
                colors=[ColorRGBA(r=1.0, a=1.0) for _ in range(4)],
                text=f'marker {i}',
            )
            for i in range(100)
        ]
    )
    return messages


# --- the other libraries ---------------------------------------------------------------


def rosbags_codec(name: str, message: Any) -> tuple[Callable[[], Any], Callable[[], Any]] | None:
    from zros.cdr.layout import VALUE_CODES
    from zros.cdr.model import Kind
    from zros.cdr.naming import attribute_name
    from zros.cdr.typestore import PLACEHOLDER_FIELD

    store = REGISTRY.typestore

    def convert(value: Any) -> Any:
        definition = REGISTRY.message_definition(value.__msgtype__)
        cls = store.types[value.__msgtype__]
        if not definition.fields:
            return cls(**{PLACEHOLDER_FIELD: 0})
        kwargs = {}
        for f in definition.fields:
            item = getattr(value, attribute_name(f.name))
            if f.type.is_nested:
                item = convert(item) if f.type.kind is Kind.SCALAR else [convert(x) for x in item]
            elif f.type.is_primitive and f.type.kind is not Kind.SCALAR:
                item = np.asarray(item, dtype=VALUE_CODES[f.type.base])
            kwargs[attribute_name(f.name)] = item
        return cls(**kwargs)

    converted = convert(message)
    data = bytes(store.serialize_cdr(converted, message.__msgtype__))
    type_name = message.__msgtype__
    return (
        lambda: store.serialize_cdr(converted, type_name),
        lambda: store.deserialize_cdr(data, type_name),
    )


def mcap_fast_codec(name: str, message: Any) -> tuple[Callable[[], Any], Callable[[], Any]] | None:
    """mcap-ros2-support-fast's generated codec, built from the bag-style definition text; it
    encodes the zros message itself (it reads attributes) and decodes into its own classes."""
    try:
        from mcap_ros2_support_fast import DecoderFactory, ROS2EncoderFactory
    except ImportError:
        return None
    from types import SimpleNamespace

    type_name = message.__msgtype__
    text = REGISTRY.typestore.generate_msgdef(type_name, ros_version=2)[0]
    schema = SimpleNamespace(id=1, name=type_name, encoding='ros2msg', data=text.encode())
    decoder = DecoderFactory().decoder_for('cdr', schema)
    encoder = ROS2EncoderFactory().encoder_for(schema)
    if decoder is None or encoder is None:
        return None
    data = cdr.encode(message)
    if bytes(encoder(message)) != data:
        raise AssertionError(f'mcap-ros2-support-fast encodes {name} differently')
    return (lambda: encoder(message), lambda: decoder(data))


def pycdr2_codec(name: str, message: Any) -> tuple[Callable[[], Any], Callable[[], Any]] | None:
    from zros.cdr.pycdr2 import pycdr2_class, to_pycdr2

    if 'Image 1920' in name or 'PointCloud2' in name:
        return None  # minutes per message: pycdr2 handles byte sequences element by element
    try:
        cls = pycdr2_class(type(message))  # imports pycdr2, an optional package
    except ImportError:
        return None
    obj = to_pycdr2(message)
    data = obj.serialize()
    return (obj.serialize, lambda: cls.deserialize(data))


def rclpy_codec(name: str, message: Any) -> tuple[Callable[[], Any], Callable[[], Any]] | None:
    try:
        from rclpy.serialization import deserialize_message, serialize_message
    except ImportError:
        return None
    from zros.cdr.model import Kind
    from zros.cdr.naming import attribute_name

    def convert(value: Any) -> Any:
        out = rclpy_class(value.__msgtype__)()
        for f in REGISTRY.message_definition(value.__msgtype__).fields:
            item = getattr(value, attribute_name(f.name))
            if f.type.is_nested:
                item = convert(item) if f.type.kind is Kind.SCALAR else [convert(x) for x in item]
            elif f.type.base == 'byte' and f.type.kind is Kind.SCALAR:
                item = bytes([item])
            setattr(out, f.name, item)
        return out

    try:
        converted = convert(message)
        cls = type(converted)
    except (ImportError, AttributeError):
        return None  # a message package not on PyPI (tf2_msgs)
    data = serialize_message(converted)
    return (lambda: serialize_message(converted), lambda: deserialize_message(data, cls))


# --- construction -------------------------------------------------------------------------


def constructions(C: Callable[[str], Any]) -> dict[str, Callable[[], Any]]:  # noqa: N803
    """Keyword constructions a node runs per message, and one attribute assignment, with the
    classes ``C(type_name)`` gives."""
    Float32 = C('std_msgs/msg/Float32')
    String = C('std_msgs/msg/String')
    Vector3 = C('geometry_msgs/msg/Vector3')
    Twist = C('geometry_msgs/msg/Twist')
    Header = C('std_msgs/msg/Header')
    Time = C('builtin_interfaces/msg/Time')
    Range = C('sensor_msgs/msg/Range')
    Pose = C('geometry_msgs/msg/Pose')
    Point = C('geometry_msgs/msg/Point')
    Quaternion = C('geometry_msgs/msg/Quaternion')
    header = Header(stamp=Time(sec=1740933158, nanosec=226629828), frame_id='ir')
    message = Range()

    def assign() -> None:
        message.range = 0.25

    return {
        'Float32(data=)': lambda: Float32(data=1.5),
        'String(data=)': lambda: String(data='hello world'),
        'Time(sec=, nanosec=)': lambda: Time(sec=1740933158, nanosec=226629828),
        'Twist(2 x Vector3(...))': lambda: Twist(
            linear=Vector3(x=0.5, y=0.1, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.3)
        ),
        'Pose(Point, Quaternion)': lambda: Pose(
            position=Point(x=1.0, y=2.0, z=0.0), orientation=Quaternion(w=1.0)
        ),
        'Range(header=, 5 scalars)': lambda: Range(
            header=header,
            radiation_type=1,
            field_of_view=0.1,
            min_range=0.04,
            max_range=0.3,
            range=0.1,
        ),
        'Range() defaults': Range,
        'range.range = 0.25': assign,
    }


def rclpy_class(type_name: str) -> Any:
    """rclpy's class of a message type (ImportError when its package is not installed)."""
    import importlib

    package, kind, short = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), short)


def print_constructions(repeats: int, budget: float) -> None:
    """Microseconds per construction, zros and rclpy."""
    try:
        theirs = constructions(rclpy_class)
    except ImportError:
        theirs = {}
    print(f'\n{"construction with keywords":32} | {"zros":>8} {"rclpy":>8}')
    print('-' * 52)
    for name, build in constructions(C).items():
        ours = best_time(build, repeats, budget)
        other = best_time(theirs[name], repeats, budget) if name in theirs else None
        print(f'{name:32} | {_fmt(ours):>8} {_fmt(other):>8}')


# --- timing ------------------------------------------------------------------------------


def best_time(function: Callable[[], Any], repeats: int, budget: float) -> float:
    """Seconds per call: the best of ``repeats`` runs, each sized to take about ``budget``."""
    return best_times({'': function}, repeats, budget)['']


def best_times(
    functions: dict[str, Callable[[], Any]], repeats: int, budget: float
) -> dict[str, float]:
    """Seconds per call of each function: the best of ``repeats`` runs, each sized to take
    about ``budget``. The runs interleave (every function's first run, then every second...):
    this VM's speed drifts by more than the differences measured, within seconds, and run in
    blocks one competitor would get the fast moments and the next the slow."""
    numbers = {}
    for key, function in functions.items():
        start = time.perf_counter()
        function()
        once = max(time.perf_counter() - start, 1e-7)
        numbers[key] = max(1, min(100_000, int(budget / once)))
    best = dict.fromkeys(functions, float('inf'))
    for _ in range(repeats):
        for key, function in functions.items():
            number = numbers[key]
            start = time.perf_counter()
            for _ in range(number):
                function()
            best[key] = min(best[key], (time.perf_counter() - start) / number)
    return best


def _fmt(seconds: float | None) -> str:
    if seconds is None:
        return '-'
    micro = seconds * 1e6
    return f'{micro:.2f}' if micro < 100 else f'{micro:.0f}'


def _ratio(a: float | None, b: float | None) -> str:
    return f'{a / b:.2f}' if a and b else '-'


LIBRARIES = {
    'mcapf': mcap_fast_codec,
    'rosbags': rosbags_codec,
    'pycdr2': pycdr2_codec,
    'rclpy': rclpy_codec,
}
ENCODERS = ('zros', 'mcapf', 'rosbags', 'pycdr2', 'rclpy')
DECODERS = ('name', 'cls', 'mcapf', 'rosbags', 'pycdr2', 'rclpy')


def measure(name: str, message: Any, repeats: int, budget: float) -> dict[str, float | None]:
    """One run of every codec on one message: seconds per call by column."""
    data = cdr.encode(message)
    cls = type(message)
    type_name = cls.__msgtype__
    target = memoryview(bytearray(len(data)))  # bytearray slice assignment is slower
    view = memoryview(bytes(8) + data)[8:]  # at an offset that keeps the bytes' alignment

    def copy_once() -> None:
        target[:] = data

    functions: dict[str, Callable[[], Any]] = {
        'zros_enc': lambda: cdr.encode(message),
        'name_dec': lambda: cdr.decode(type_name, data),
        'cls_dec': lambda: decode_class(cls, data),
        'view_dec': lambda: cdr.decode(type_name, view),
        'memcpy': copy_once,
    }
    row: dict[str, float | None] = {}
    for label, make in LIBRARIES.items():
        # a copy: other libraries iterate a struct sequence, which turns zros's packed array
        # into objects, and the next run would time zros's encode of the objects instead
        codec = make(name, message.copy())
        if codec is None:
            row[f'{label}_enc'] = row[f'{label}_dec'] = None
            continue
        functions[f'{label}_enc'], functions[f'{label}_dec'] = codec
    row.update(best_times(functions, repeats, budget))
    return row


def median_rows(runs: list[dict[str, float | None]]) -> dict[str, float | None]:
    """The median of each column over runs (None where a library is missing)."""
    out: dict[str, float | None] = {}
    for key in runs[0]:
        values = [run[key] for run in runs if run[key] is not None]
        out[key] = statistics.median(values) if values else None  # type: ignore[type-var]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer, shorter runs')
    parser.add_argument('--only', help='only messages whose name contains this text')
    parser.add_argument('--runs', type=int, default=1, help='report the median of this many runs')
    args = parser.parse_args()
    set_default_registry(REGISTRY)  # cdr.decode(type_name, ...) resolves names in it
    repeats, budget = (3, 0.02) if args.quick else (7, 0.05)

    versions = []
    for package in (
        'eclipse-zenoh',
        'numpy',
        'mcap-ros2-support-fast',
        'rosbags',
        'pycdr2',
        'ros-jazzy-rclpy',
    ):
        try:
            versions.append(f'{package} {metadata.version(package)}')
        except metadata.PackageNotFoundError:
            versions.append(f'{package} (not installed)')
    print(
        f'zros CDR codec benchmark: microseconds per message, best of {repeats} repeats, '
        f'median of {args.runs} run(s)'
    )
    print(f'Python {platform.python_version()} on {platform.machine()}; ' + ', '.join(versions))
    print('decode: name = cdr.decode(type_name, data), cls = decode(cls, data) (subscribers)')
    print()
    header = (
        f'{"message":24} {"bytes":>8} | '
        + ' '.join(f'{c:>7}' for c in ENCODERS)
        + ' | '
        + ' '.join(f'{c:>7}' for c in DECODERS)
        + f' | {"memcpy":>7} | {"view":>7} {"v/b":>5} | {"enc/mf":>6} {"dec/mf":>6} {"enc/rb":>6} {"dec/rb":>6}'
    )
    print(f'{"":33} | {"encode":^39} | {"decode":^47} |')
    print(header)
    print('-' * len(header))
    results: dict[str, dict[str, float | None]] = {}
    for name, message in build_messages().items():
        if args.only and args.only not in name:
            continue
        runs = [measure(name, message, repeats, budget) for _ in range(max(1, args.runs))]
        row = results[name] = median_rows(runs)
        print(
            f'{name:24} {len(cdr.encode(message)):>8} | '
            + ' '.join(f'{_fmt(row[f"{c}_enc"]):>7}' for c in ENCODERS)
            + ' | '
            + ' '.join(f'{_fmt(row[f"{c}_dec"]):>7}' for c in DECODERS)
            + f' | {_fmt(row["memcpy"]):>7} | '
            + f'{_fmt(row["view_dec"]):>7} {_ratio(row["view_dec"], row["name_dec"]):>5} | '
            + f'{_ratio(row["zros_enc"], row["mcapf_enc"]):>6} '
            + f'{_ratio(row["name_dec"], row["mcapf_dec"]):>6} '
            + f'{_ratio(row["zros_enc"], row["rosbags_enc"]):>6} '
            + f'{_ratio(row["name_dec"], row["rosbags_dec"]):>6}'
        )
    print_goals(results)
    if not args.only:
        print_constructions(repeats, budget)


SMALL = ('String', 'Twist', 'Odometry', 'Imu', 'TFMessage(10)')
MEDIUM = ('LaserScan(720)', 'PoseArray(1000)', 'MarkerArray(100)')


def print_goals(results: dict[str, dict[str, float | None]]) -> None:
    """Check the issue's goals against this run."""
    goals: list[tuple[str, bool]] = []

    def value(name: str, key: str) -> float:
        return float(results[name][key])  # type: ignore[arg-type]

    have_mcapf = any(row['mcapf_dec'] for row in results.values())
    for name in SMALL:
        if name not in results or not have_mcapf:
            continue
        for api in ('name', 'cls'):
            ratio = value(name, f'{api}_dec') / value(name, 'mcapf_dec')
            goals.append(
                (
                    f'{name} decode ({api}) {ratio:.2f}x mcap-ros2-support-fast (goal <= 0.8x)',
                    ratio <= 0.8,
                )
            )
        ratio = value(name, 'zros_enc') / value(name, 'mcapf_enc')
        goals.append((f'{name} encode {ratio:.2f}x mcap-ros2-support-fast (goal < 1x)', ratio < 1))
    for name in SMALL + MEDIUM:
        if name in results:
            for kind, key in (('enc', 'zros_enc'), ('dec', 'name_dec')):
                ratio = value(name, key) / value(name, f'rosbags_{kind}')
                goals.append(
                    (f'{name} {kind}ode {ratio:.3f}x rosbags (goal <= 0.35x)', ratio <= 0.35)
                )
    for name in ('LaserScan(720)', 'Image 640x480', 'Image 1920x1080', 'PointCloud2(100k)'):
        if name in results:
            micro = value(name, 'name_dec') * 1e6
            goals.append((f'{name} decode {micro:.2f} us, zero-copy (goal <= 10 us)', micro <= 10))
    for name in results:
        ratio = value(name, 'view_dec') / value(name, 'name_dec')
        goals.append(
            (f'{name} decode of a memoryview {ratio:.2f}x bytes (goal <= 1.15x)', ratio <= 1.15)
        )
    if 'Image 1920x1080' in results:
        ratio = value('Image 1920x1080', 'zros_enc') / value('Image 1920x1080', 'memcpy')
        goals.append((f'Image 1920x1080 encode {ratio:.2f}x memcpy (goal <= 1.5x)', ratio <= 1.5))
    print('\ngoals')
    for text, met in goals:
        print(f'  {"met   " if met else "MISSED"}  {text}')
    if 'PoseArray(1000) objects' in results:
        ratio = value('PoseArray(1000) objects', 'zros_enc') / value(
            'PoseArray(1000) objects', 'rosbags_enc'
        )
        print(
            f'  (info)  PoseArray(1000) built from 1000 Pose objects: encode {ratio:.2f}x rosbags'
        )


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()
