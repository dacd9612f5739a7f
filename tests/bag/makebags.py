"""Small recordings made by hand for the error paths (in tmp_path, never in the repository)."""

from __future__ import annotations

import sqlite3
from pathlib import Path

QOS = ''


def make_db3(
    path: Path,
    topics: list[tuple[str, str]],
    messages: list[tuple[int, int, bytes]],
    definitions: dict[str, str] | None = None,
) -> Path:
    """A bare rosbag2 ``.db3``: ``topics`` are (name, type); ``messages`` are (topic index,
    timestamp, CDR bytes); ``definitions`` (type -> .msg text) fill the message_definitions
    table of schema 4, else the file has none (as rosbag2 before Iron wrote it)."""
    db = sqlite3.connect(path)
    try:
        db.executescript(
            """
            CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
              serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL{hash});
            CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
              timestamp INTEGER NOT NULL, data BLOB NOT NULL);
            """.replace('{hash}', ', type_description_hash TEXT NOT NULL' if definitions else '')
        )
        if definitions is not None:
            db.executescript(
                """
                CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
                INSERT INTO schema VALUES (4, 'jazzy');
                CREATE TABLE message_definitions(id INTEGER PRIMARY KEY,
                  topic_type TEXT NOT NULL, encoding TEXT NOT NULL,
                  encoded_message_definition TEXT NOT NULL, type_description_hash TEXT NOT NULL);
                """
            )
            for type_name, text in definitions.items():
                db.execute(
                    'INSERT INTO message_definitions(topic_type, encoding, '
                    'encoded_message_definition, type_description_hash) VALUES (?, ?, ?, ?)',
                    (type_name, 'ros2msg', text, ''),
                )
        for index, (name, type_name) in enumerate(topics, 1):
            values: tuple[object, ...] = (index, name, type_name, 'cdr', QOS)
            if definitions is not None:
                values += ('',)
            db.execute(f'INSERT INTO topics VALUES ({", ".join("?" * len(values))})', values)
        for topic, timestamp, data in messages:
            db.execute(
                'INSERT INTO messages(topic_id, timestamp, data) VALUES (?, ?, ?)',
                (topic + 1, timestamp, data),
            )
        db.commit()
    finally:
        db.close()
    return path


def make_sensor_bag(path: Path, count: int, storage: str = 'mcap', vary: bool = True) -> Path:
    """A rosbag2 folder of Imu (/imu), LaserScan (/scan) and Odometry (/odom), written by
    rosbags. With ``vary`` the frame ids and scan lengths change from message to message."""
    import numpy as np
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    T = store.types
    rng = np.random.default_rng(3)
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3

    def header(index: int, frame: str) -> object:
        name = frame + ('_x' * (index % 3) if vary else '')
        stamp = T['builtin_interfaces/msg/Time'](sec=index, nanosec=index * 7)
        return T['std_msgs/msg/Header'](stamp=stamp, frame_id=name)

    def vector(x: float, y: float, z: float) -> object:
        return T['geometry_msgs/msg/Vector3'](x=x, y=y, z=z)

    with Writer(path, version=9, storage_plugin=plugin) as writer:
        imu = writer.add_connection('/imu', 'sensor_msgs/msg/Imu', typestore=store)
        scan = writer.add_connection('/scan', 'sensor_msgs/msg/LaserScan', typestore=store)
        odom = writer.add_connection('/odom', 'nav_msgs/msg/Odometry', typestore=store)
        for index in range(count):
            stamp = 1_000_000_000 + index * 1_000_000
            values = rng.random(40)
            kind = index % 3
            if kind == 0:
                message = T['sensor_msgs/msg/Imu'](
                    header=header(index, 'imu'),
                    orientation=T['geometry_msgs/msg/Quaternion'](*values[:4]),
                    orientation_covariance=values[4:13],
                    angular_velocity=vector(*values[13:16]),
                    angular_velocity_covariance=values[16:25],
                    linear_acceleration=vector(*values[25:28]),
                    linear_acceleration_covariance=values[28:37],
                )
                connection, type_name = imu, 'sensor_msgs/msg/Imu'
            elif kind == 1:
                size = 32 + (index % 2 if vary else 0)
                message = T['sensor_msgs/msg/LaserScan'](
                    header=header(index, 'laser'),
                    angle_min=-1.0,
                    angle_max=1.0,
                    angle_increment=2.0 / size,
                    time_increment=0.0,
                    scan_time=0.1,
                    range_min=0.1,
                    range_max=30.0,
                    ranges=rng.random(size).astype(np.float32),
                    intensities=rng.random(size if index % 5 else 0).astype(np.float32),
                )
                connection, type_name = scan, 'sensor_msgs/msg/LaserScan'
            else:
                point = T['geometry_msgs/msg/Point'](*values[:3])
                pose = T['geometry_msgs/msg/Pose'](
                    point, T['geometry_msgs/msg/Quaternion'](*values[3:7])
                )
                twist = T['geometry_msgs/msg/Twist'](vector(*values[7:10]), vector(*values[10:13]))
                message = T['nav_msgs/msg/Odometry'](
                    header=header(index, 'odom'),
                    child_frame_id='base_link',
                    pose=T['geometry_msgs/msg/PoseWithCovariance'](pose, rng.random(36)),
                    twist=T['geometry_msgs/msg/TwistWithCovariance'](twist, rng.random(36)),
                )
                connection, type_name = odom, 'nav_msgs/msg/Odometry'
            writer.write(connection, stamp, store.serialize_cdr(message, type_name))
    return path


def make_points_mcap(
    path: Path,
    count: int,
    compression: str = 'zstd',
    chunked: bool = True,
    shuffle: bool = True,
    *,
    chunk_size: int = 2048,
) -> Path:
    """A bare ``.mcap`` of geometry_msgs/Point on /point written by the mcap library, chunks
    compressed with ``compression`` ('zstd', 'lz4', 'none'), or no chunks and no summary.
    With ``shuffle`` every 7th message is stamped before the one preceding it."""
    from mcap.writer import CompressionType, IndexType, Writer

    from zros.cdr import encode, new_message

    kind = {'zstd': CompressionType.ZSTD, 'lz4': CompressionType.LZ4, 'none': CompressionType.NONE}
    with path.open('wb') as stream:
        writer = Writer(
            stream,
            chunk_size=chunk_size,
            compression=kind[compression],
            use_chunking=chunked,
            index_types=IndexType.ALL if chunked else IndexType.NONE,
            use_summary_offsets=chunked,
            use_statistics=chunked,
        )
        writer.start(profile='ros2', library='zros tests')
        schema = writer.register_schema(
            'geometry_msgs/msg/Point', 'ros2msg', b'float64 x\nfloat64 y\nfloat64 z\n'
        )
        channel = writer.register_channel('/point', 'cdr', schema)
        for index in range(count):
            data = encode(new_message('geometry_msgs/msg/Point', x=index, y=-index, z=0.5))
            stamp = 1000 + index * 10 - (15 if shuffle and index % 7 == 6 else 0)
            writer.add_message(channel, log_time=stamp, data=data, publish_time=stamp)
        writer.finish()
    return path


def make_ros1_bag(
    path: Path,
    count: int,
    compression: str | None = None,
    bad_definition: bool = False,
    chunk_threshold: int = 4096,
) -> Path:
    """A ROS 1 bag of String on /a and Point on /b (``count`` each, interleaved) in chunks of
    about ``chunk_threshold`` bytes, ``compression`` 'bz2', 'lz4' or None; with
    ``bad_definition`` a third topic /c whose connection's message definition does not parse."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    string, point = store.types['std_msgs/msg/String'], store.types['geometry_msgs/msg/Point']
    writer = Writer(path)
    if compression:
        writer.set_compression(Writer.CompressionFormat[compression.upper()])
    writer.chunk_threshold = chunk_threshold
    with writer:
        a = writer.add_connection('/a', 'std_msgs/msg/String', typestore=store)
        b = writer.add_connection('/b', 'geometry_msgs/msg/Point', typestore=store)
        c = None
        if bad_definition:
            c = writer.add_connection(
                '/c', 'zros_test/msg/Broken', msgdef='float64 x\n}{ not a field', md5sum='0' * 32
            )
        for index in range(count):
            text = string(data=f'message {index} ' * 3)
            writer.write(a, 1000 + index * 10, store.serialize_ros1(text, string.__msgtype__))
            spot = point(x=float(index), y=0.0, z=0.0)
            writer.write(b, 1005 + index * 10, store.serialize_ros1(spot, point.__msgtype__))
            if c is not None and index % 10 == 0:
                writer.write(c, 1007 + index * 10, bytes(8))
    return path


def make_schema_mcap(
    path: Path,
    schemas: list[tuple[str, str, str, bytes]],
    messages: list[tuple[int, int, bytes]],
) -> Path:
    """A finished ros2-profile MCAP file with the mcap library's writer: a channel per
    ``(topic, type, schema encoding, schema data)`` and ``(channel index, time, data)`` each."""
    from mcap.writer import Writer

    with path.open('wb') as stream:
        writer = Writer(stream)
        writer.start(profile='ros2', library='test')
        channels = [
            writer.register_channel(topic, 'cdr', writer.register_schema(name, encoding, data))
            for topic, name, encoding, data in schemas
        ]
        for index, stamp, data in messages:
            writer.add_message(channels[index], log_time=stamp, data=data, publish_time=stamp)
        writer.finish()
    return path
