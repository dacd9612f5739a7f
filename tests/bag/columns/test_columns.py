"""Numeric columns equal the fields of rosbags' decoding, on the fast path and the slow one."""

from __future__ import annotations

import re
import struct
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests.bag.makebags import make_db3, make_points_mcap, make_sensor_bag
from tests.bag.reference import RECORDINGS, rosbags_messages
from zros.bag import Bag, BagError, Connection, RawMessage
from zros.bag.columns import extract, rows
from zros.cdr import encode, new_message


def _pick(message: Any, path: str) -> Any:
    for part in path.split('.'):
        message = getattr(message, part if hasattr(message, part) else part + '_')
    return message


def assert_columns_match(path: Path, topic: str, got: dict[str, np.ndarray]) -> None:
    """Every column equals the field rosbags decodes, message by message."""
    theirs = [(stamp, m) for t, _, stamp, m in rosbags_messages(path) if t == topic]
    assert got['time'].tolist() == [stamp for stamp, _ in theirs]
    for name, column in got.items():
        if name == 'time':
            continue
        assert len(column) == len(theirs), name
        for row, (_, message) in zip(column, theirs, strict=True):
            expected = np.asarray(_pick(message, name))
            if expected.dtype == np.int8 and column.dtype != object and column.dtype == np.uint8:
                expected = expected.astype(np.int64) % 256  # byte: rosbags reads int8
            assert np.array_equal(np.asarray(row), expected, equal_nan=True), (topic, name)


def _topics(path: Path) -> list[str]:
    with Bag(path) as bag:
        return [t for t, info in bag.topics.items() if info.count]


@pytest.mark.parametrize('name', RECORDINGS)
def test_recordings_columns_equal_rosbags(testdata: Path, name: str) -> None:
    path = testdata / name
    for topic in _topics(path):
        with Bag(path) as bag:
            got = bag.columns(topic)
        assert_columns_match(path, topic, got)


@pytest.fixture(scope='module')
def sensor_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_sensor_bag(tmp_path_factory.mktemp('sensors') / 'bag', 300)


@pytest.mark.parametrize('topic', ['/imu', '/scan', '/odom'])
def test_sensor_columns_equal_rosbags(sensor_bag: Path, topic: str) -> None:
    with Bag(sensor_bag) as bag:
        got = bag.columns(topic)
    assert_columns_match(sensor_bag, topic, got)


def test_fast_and_slow_paths_agree(sensor_bag: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: Any) -> Any:
        raise rows.Unplannable('forced')

    def unexpected(*args: Any) -> Any:
        raise AssertionError('the fast path should read these messages')

    with Bag(sensor_bag) as bag:
        monkeypatch.setattr(extract, '_slow', unexpected)
        fast = {t: bag.columns(t) for t in ('/imu', '/scan', '/odom')}
        monkeypatch.undo()
        monkeypatch.setattr(extract, 'read_rows', refuse)
        slow = {t: bag.columns(t) for t in ('/imu', '/scan', '/odom')}
    for topic, found in fast.items():
        assert found.keys() == slow[topic].keys()
        for name, a in found.items():
            b = slow[topic][name]
            assert a.dtype == b.dtype and a.shape == b.shape, (topic, name)
            for x, y in zip(a, b, strict=True):
                assert np.array_equal(x, y), (topic, name)


def test_uniform_columns_are_2d_and_batches_join(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = make_sensor_bag(tmp_path / 'even', 90, storage='sqlite3', vary=False)
    monkeypatch.setattr(extract, 'BATCH', 7)
    with Bag(path) as bag:
        scan = bag.columns('/scan', ['ranges', 'angle_max'])
        odom = bag.columns('/odom', ['pose.pose.position'])
        table = bag.to_numpy('/odom', ['pose.pose.position.x', 'pose.covariance'])
    assert scan['ranges'].shape == (30, 32) and scan['ranges'].dtype == np.float32
    assert list(scan) == ['time', 'ranges', 'angle_max']
    assert list(odom) == ['time', *[f'pose.pose.position.{a}' for a in 'xyz']]
    assert_columns_match(path, '/scan', scan)
    assert_columns_match(path, '/odom', odom)
    assert table.dtype.names == ('time', 'pose.pose.position.x', 'pose.covariance')
    assert table['pose.covariance'].shape == (30, 36)
    assert np.array_equal(table['pose.pose.position.x'], odom['pose.pose.position.x'])


def test_ragged_sequences_are_object_columns(sensor_bag: Path) -> None:
    with Bag(sensor_bag) as bag:
        scan = bag.columns('/scan', ['ranges', 'intensities'])
        assert scan['ranges'].dtype == object
        assert {len(r) for r in scan['ranges']} == {32, 33}
        assert {len(r) for r in scan['intensities']} == {0, 32, 33}
        with pytest.raises(BagError, match='different lengths'):
            bag.to_numpy('/scan', ['ranges'])


def test_field_errors(sensor_bag: Path) -> None:
    with Bag(sensor_bag) as bag:
        with pytest.raises(BagError, match=r"has no field 'pose\.nothing'"):
            bag.columns('/odom', ['pose.nothing'])
        with pytest.raises(BagError, match="'child_frame_id' is not numeric"):
            bag.columns('/odom', ['child_frame_id'])
        with pytest.raises(BagError, match='no topic /none'):
            bag.columns('/none')


def test_empty_topic_gives_empty_columns(testdata: Path) -> None:
    with Bag(testdata / 'ros2' / 'empty_bag') as bag:
        got = bag.columns('/rosout', ['level', 'stamp.sec'])
    assert got['time'].shape == (0,)
    assert got['level'].dtype == np.uint8 and got['level'].shape == (0,)


def test_time_window(sensor_bag: Path) -> None:
    with Bag(sensor_bag) as bag:
        every = bag.columns('/imu', ['orientation.w'])
        start, end = int(every['time'][10]), int(every['time'][20])
        part = bag.columns('/imu', ['orientation.w'], start=start, end=end)
    assert np.array_equal(part['orientation.w'], every['orientation.w'][10:20])


def _point(x: float) -> bytes:
    return encode(new_message('geometry_msgs/msg/Point', x=x, y=2.0, z=3.0))


def test_big_endian_and_unplannable_messages_are_decoded_one_by_one(tmp_path: Path) -> None:
    big = b'\x00\x00\x00\x00' + struct.pack('>ddd', 7.0, 8.0, 9.0)
    joint = new_message('sensor_msgs/msg/JointState', name=['a', 'b'], position=[0.5, 1.5])
    path = make_db3(
        tmp_path / 'mixed.db3',
        [('/point', 'geometry_msgs/msg/Point'), ('/joints', 'sensor_msgs/msg/JointState')],
        [(0, 1, _point(1.0)), (0, 2, big), (1, 3, encode(joint))],
    )
    with Bag(path) as bag:
        point = bag.columns('/point')
        joints = bag.columns('/joints', ['position'])
    assert point['x'].tolist() == [1.0, 7.0]
    assert point['z'].tolist() == [3.0, 9.0]
    # a sequence of strings comes before position: no plan reaches it
    assert joints['position'].tolist() == [[0.5, 1.5]]


def test_data_that_fits_no_definition_is_skipped_or_an_error_if_strict(tmp_path: Path) -> None:
    path = make_db3(
        tmp_path / 'long.db3',
        [('/point', 'geometry_msgs/msg/Point')],
        [(0, 1, _point(1.0)), (0, 2, _point(1.0) + bytes(8))],
    )
    with Bag(path) as bag:
        columns = bag.columns('/point')
        assert columns['time'].tolist() == [1] and columns['x'].tolist() == [1.0]
        assert [(s.row, s.topic, s.lost) for s in bag.skipped] == [(2, '/point', 1)]
    with (
        Bag(path, strict=True) as bag,
        pytest.raises(BagError, match='cannot decode the message of /point at 2'),
    ):
        bag.columns('/point')


def test_attribute_spellings_are_accepted(tmp_path: Path) -> None:
    from zros.bag.columns.plan import ros_path

    assert ros_path('a.from_.b_') == 'a.from.b_'


def test_dataframe_needs_pandas(sensor_bag: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, 'pandas', None)
    with Bag(sensor_bag) as bag, pytest.raises(ImportError, match='pip install pandas'):
        bag.to_dataframe('/imu')


def test_dataframe(sensor_bag: Path) -> None:
    pytest.importorskip('pandas')
    with Bag(sensor_bag) as bag:
        frame = bag.to_dataframe('/imu', ['orientation.w', 'orientation_covariance'])
        raw = bag.columns('/imu', ['orientation.w', 'orientation_covariance'])
    assert list(frame.columns)[:3] == ['time', 'orientation.w', 'orientation_covariance[0]']
    assert np.array_equal(frame['orientation_covariance[8]'], raw['orientation_covariance'][:, 8])


@pytest.mark.parametrize(
    ('compression', 'chunked'), [('zstd', True), ('lz4', True), ('none', True), ('none', False)]
)
def test_mcap_chunks_of_every_kind(tmp_path: Path, compression: str, chunked: bool) -> None:
    path = make_points_mcap(tmp_path / 'points.mcap', 500, compression, chunked, shuffle=chunked)
    with Bag(path) as bag:
        got = bag.columns('/point')
        window = bag.columns('/point', ['x'], start=2000, end=3000)
        typed = [(s, m.x) for _, s, m in bag.messages()]
    assert_columns_match(path, '/point', got)
    assert got['time'].tolist() == [s for s, _ in typed]
    assert window['x'].tolist() == [x for s, x in typed if 2000 <= s < 3000]


def test_unindexed_mcap_out_of_time_order_is_refused(tmp_path: Path) -> None:
    path = make_points_mcap(tmp_path / 'points.mcap', 50, 'none', chunked=False, shuffle=True)
    with Bag(path) as bag, pytest.raises(BagError, match='not in timestamp order'):
        bag.columns('/point')


def _forbid(monkeypatch: pytest.MonkeyPatch) -> None:
    def unexpected(*args: Any) -> Any:
        raise AssertionError('read message by message')

    monkeypatch.setattr(extract, '_message_blocks', unexpected)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_storages_are_read_in_bulk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, storage: str
) -> None:
    path = make_sensor_bag(tmp_path / 'bulk', 60, storage=storage)
    _forbid(monkeypatch)
    with Bag(path) as bag:
        got = bag.columns('/odom', ['pose.pose.position.x'])
        window = bag.columns('/odom', ['pose.pose.position.x'], start=1_010_000_000)
    assert_columns_match(path, '/odom', got)
    assert window['time'].tolist() == [t for t in got['time'].tolist() if t >= 1_010_000_000]


def test_compressed_messages_are_read_one_by_one(tmp_path: Path) -> None:
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    path = tmp_path / 'compressed'
    writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
    with writer:
        conn = writer.add_connection('/point', 'geometry_msgs/msg/Point', typestore=store)
        for index in range(20):
            writer.write(conn, 100 + index, _point(float(index)))
    with Bag(path) as bag:
        assert bag.source.compression_mode == 'message'
        got = bag.columns('/point', ['x'])
        assert [m.x for _, _, m in bag.messages()] == list(range(20))
    assert got['x'].tolist() == list(range(20))


def test_a_message_index_that_does_not_match_is_refused() -> None:
    from zros.bag.read import mcap_chunks

    record = bytes([5]) + (22 + 3).to_bytes(8, 'little') + (1).to_bytes(2, 'little')
    record += bytes(4) + (50).to_bytes(8, 'little') * 2 + b'abc'
    entries = np.array([(50, 0)], mcap_chunks._INDEX)
    block = mcap_chunks._block(record, 1, entries)
    assert list(block.data) == [b'abc'] and block.times.tolist() == [50]
    for wrong in (np.array([(50, 3)], mcap_chunks._INDEX), np.array([(51, 0)], mcap_chunks._INDEX)):
        with pytest.raises(mcap_chunks.Unsupported):
            mcap_chunks._block(record, 1, wrong)
    with pytest.raises(mcap_chunks.Unsupported):
        mcap_chunks._block(record, 2, entries)
    with pytest.raises(mcap_chunks.Unsupported):
        mcap_chunks._block(record[:-1], 1, entries)


@pytest.mark.parametrize('compression', ['none', 'zstd', 'lz4'])
def test_a_mapped_file_gives_the_payloads_a_read_one_does(tmp_path: Path, compression: str) -> None:
    from zros.bag.read import mcap_chunks

    path = make_points_mcap(tmp_path / 'points.mcap', 300, compression, True, shuffle=False)

    def payloads(mapped: bool) -> list[list[bytes]]:
        channels = {1: Connection(1, '/points', 'test_msgs/msg/Point', '', '', 'cdr', 300, '')}
        found = mcap_chunks.read_blocks(path, channels, None, None, mapped=mapped)
        return [list(block.data) for blocks in found for block in blocks]

    read = payloads(False)
    assert sum(map(len, read)) == 300
    assert payloads(True) == read


def test_a_damaged_chunk_in_a_mapped_file_is_refused(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    from zros.bag.read import mcap_chunks

    path = make_points_mcap(tmp_path / 'points.mcap', 300, 'none', True, shuffle=False)
    with path.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    at = min(index.chunk_start_offset for index in summary.chunk_indexes)
    data = bytearray(path.read_bytes())
    data[at] = 0x05  # a message record's opcode where a chunk should begin
    path.write_bytes(bytes(data))
    channels = {1: Connection(1, '/points', 'test_msgs/msg/Point', '', '', 'cdr', 300, '')}
    with pytest.raises(mcap_chunks.Unsupported, match='no chunk where'):
        list(mcap_chunks.read_blocks(path, channels, None, None, mapped=True))
    view = memoryview(bytes([0x06]) + bytes(20))  # cut inside the chunk's header
    with pytest.raises(mcap_chunks.Unsupported, match='damaged chunk record'):
        mcap_chunks._mapped_chunk(view, 0)
    header = bytes([0x06]) + bytes(8) + bytes(24) + bytes(4) + bytes(4) + (99).to_bytes(8, 'little')
    with pytest.raises(mcap_chunks.Unsupported, match='beyond the end'):
        mcap_chunks._mapped_chunk(memoryview(header + bytes(10)), 0)


def _scans(path: Path, lengths: list[int]) -> Path:
    """A bag of LaserScans on /scan whose ``ranges`` have the given lengths, 1 ms apart."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection('/scan', 'sensor_msgs/msg/LaserScan', typestore=store)
        for index, size in enumerate(lengths):
            scan = new_message(
                'sensor_msgs/msg/LaserScan', angle_max=float(index), ranges=[index] * size
            )
            writer.write(conn, 1_000_000 * (index + 1), encode(scan))
    return path


def test_columns_grow_past_their_count_and_turn_ragged_midway(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # batches of 7 arrays of 4 values, then of 5: the column becomes one of 1-D arrays
    path = _scans(tmp_path / 'scans', [4] * 21 + [5] * 9)
    monkeypatch.setattr(extract, 'BATCH', 7)
    monkeypatch.setattr(extract, '_capacity', lambda *args: 2)  # counts that fall short
    with Bag(path) as bag:
        scan = bag.columns('/scan', ['ranges', 'angle_max'])
        uniform = bag.columns('/scan', ['ranges'], end=22_000_000)
    assert scan['angle_max'].tolist() == list(range(30))
    assert scan['ranges'].dtype == object
    assert [row.tolist() for row in scan['ranges']] == [
        [i] * (4 if i < 21 else 5) for i in range(30)
    ]
    assert uniform['ranges'].shape == (21, 4)
    assert uniform['ranges'][:, 0].tolist() == list(range(21))
    assert_columns_match(path, '/scan', scan)


def test_chunks_read_into_memory_without_maps(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.bag.read import mcap_chunks

    path = make_points_mcap(tmp_path / 'points.mcap', 300, 'none', True, shuffle=True)
    with Bag(path) as bag:
        mapped = bag.columns('/point')

    def no_map(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError('mapped')

    monkeypatch.setattr(mcap_chunks.mmap, 'mmap', no_map)
    monkeypatch.setenv('ZROS_BAG_MMAP', '0')
    with Bag(path) as bag:
        read = bag.columns('/point')
    assert read.keys() == mapped.keys()
    for name, column in read.items():
        assert np.array_equal(column, mapped[name]), name
    monkeypatch.setenv('ZROS_BAG_MMAP', '1')
    with Bag(path) as bag, pytest.raises(AssertionError, match='mapped'):
        bag.columns('/point')


def test_messages_read_one_by_one_are_batched_by_count_and_bytes(tmp_path: Path) -> None:
    connection = Connection(1, '/point', 'geometry_msgs/msg/Point', '', '', 'cdr', 9, '')
    messages = iter([RawMessage(connection, stamp, bytes(10)) for stamp in range(9)])
    sizes = [len(extract._take(messages, 4, 25)) for _ in range(4)]
    assert sizes == [3, 3, 3, 0]  # 30 bytes reach 25 before 4 messages
    messages = iter([RawMessage(connection, stamp, bytes(10)) for stamp in range(9)])
    assert [len(extract._take(messages, 2, 1 << 20)) for _ in range(5)] == [2, 2, 2, 2, 1]


def test_slash_addresses_as_zros_plot_takes_them(testdata: Path) -> None:
    from zros.bag import AddressError
    from zros.plot import PlotError

    with Bag(testdata / 'ros2' / 'tf_nav2_mcap') as bag:
        dotted = bag.columns('/odom', ['pose.pose.position.x', 'pose.covariance'])
        whole = bag.columns('/odom/pose/pose/position/x')  # topic /odom, field pose.pose.position.x
        assert list(whole) == ['time', 'pose.pose.position.x']
        np.testing.assert_array_equal(whole['pose.pose.position.x'], dotted['pose.pose.position.x'])
        np.testing.assert_array_equal(whole['time'], dotted['time'])
        assert list(bag.columns('/odom/pose/pose/position')) == [
            'time', 'pose.pose.position.x', 'pose.pose.position.y', 'pose.pose.position.z',
        ]  # fmt: skip
        mixed = bag.columns(
            '/odom', ['pose/pose/position/x', 'twist.twist.linear.x', 'pose/covariance[3]',
                      'pose/covariance/35'],
        )  # fmt: skip
        assert set(mixed) == {
            'time', 'pose.pose.position.x', 'twist.twist.linear.x', 'pose.covariance[3]',
            'pose.covariance[35]',
        }  # fmt: skip
        np.testing.assert_array_equal(mixed['pose.covariance[3]'], dotted['pose.covariance'][:, 3])
        np.testing.assert_array_equal(
            mixed['pose.covariance[35]'], dotted['pose.covariance'][:, 35]
        )
        frame = bag.to_dataframe('/odom/pose/covariance[0]')
        assert list(frame.columns) == ['time', 'pose.covariance[0]']
        assert len(frame) == bag.topics['/odom'].count
        assert bag.to_numpy('/odom/pose/pose/position/x').dtype.names == (
            'time', 'pose.pose.position.x',
        )  # fmt: skip
        # the errors of zros plot
        for address, message in [
            ('/odom/pose/pose/speed', "pose.pose has no field 'speed' (it has: position, orient"),
            ('/odom/pose/covariance', 'pose.covariance is an array: plot an element, e.g. /odom'),
            ('/odom/child_frame_id', 'child_frame_id is a string, not a number'),
            ('/odom/pose/covariance[36]', 'pose.covariance has 36 elements, not 37'),
        ]:
            with pytest.raises(AddressError, match=f'^{re.escape(address)}: {re.escape(message)}'):
                bag.columns(address)
        with pytest.raises(PlotError, match=r"^/odom/twist/speed: twist has no field 'speed'"):
            bag.columns('/odom', ['twist/speed'])
        with pytest.raises(AddressError, match='give fields only with a topic name'):
            bag.columns('/odom/pose', ['position.x'])
        with pytest.raises(BagError, match='no topic /nothing/x in the recording'):
            bag.columns('/nothing/x')
