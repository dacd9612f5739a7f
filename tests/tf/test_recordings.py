"""Buffers from recordings (``Buffer.from_bag``) and trajectories, on the real recordings of
../shared/testdata and on small bags written here (a ROS 1 ``tf/tfMessage`` one)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from zros.bag import Bag, BagError
from zros.tf import Buffer, ExtrapolationException, trajectory

S = 10**9
TOL = 1e-9


def test_wheeled_robot_odom_frame_at_each_odom_stamp_is_that_odom_pose(testdata: Path) -> None:
    path = testdata / 'ros2' / 'tf_nav2_mcap'
    buffer = Buffer.from_bag(path)
    with Bag(path) as bag:
        (frames,) = {
            m.child_frame_id for _, _, m in bag.messages('/odom', end=bag.start_ns + 10**9)
        }
        fields = ['header.stamp.sec', 'header.stamp.nanosec', 'pose.pose.position.x',
                  'pose.pose.position.y', 'pose.pose.position.z', 'pose.pose.orientation.x',
                  'pose.pose.orientation.y', 'pose.pose.orientation.z', 'pose.pose.orientation.w']  # fmt: skip
        odom = bag.columns('/odom', fields)
    assert frames == 'base_link'
    stamps = odom['header.stamp.sec'].astype(np.int64) * 10**9 + odom['header.stamp.nanosec']
    assert len(stamps) == 2639
    t, q = buffer.lookup_transforms('odom', 'base_link', stamps, strict=True)
    position = np.c_[[odom[f'pose.pose.position.{a}'] for a in 'xyz']].T
    orientation = np.c_[[odom[f'pose.pose.orientation.{a}'] for a in 'xyzw']].T
    np.testing.assert_allclose(t, position, atol=TOL)
    np.testing.assert_allclose(q, orientation, atol=TOL)
    # and one lookup at a time says the same
    one = buffer.lookup_transform('odom', 'base_link', int(stamps[1000])).transform.translation
    assert (one.x, one.y, one.z) == pytest.approx(tuple(position[1000]), abs=TOL)


def test_nav2_tree_static_and_moving(testdata: Path) -> None:
    buffer = Buffer.from_bag(testdata / 'ros2' / 'tf_nav2_mcap')
    edges = {e.frame: e for e in buffer.edges()}
    assert sum(e.static for e in edges.values()) == 29
    assert {f for f, e in edges.items() if not e.static} == {
        'odom', 'base_link', 'left_wheel', 'right_wheel'
    }  # fmt: skip
    assert edges['base_link'].parent == 'odom' and edges['odom'].parent == 'map'
    assert edges['base_link'].length == 2639 and edges['odom'].length == 921
    assert buffer.rejections.counts == {}
    # time 0: the latest instant both map->odom and odom->base_link know
    latest = buffer.lookup_transform('map', 'base_footprint', 0)
    assert latest.header.stamp.sec * 10**9 + latest.header.stamp.nanosec == min(
        edges['odom'].newest, edges['base_link'].newest
    )


def test_trajectory_columns_at_every_stamp_the_chain_changes(testdata: Path) -> None:
    path = testdata / 'ros2' / 'tf_nav2_mcap'
    with Bag(path) as bag:
        track = trajectory(bag, 'map', 'base_footprint')
    assert list(track) == ['t', 'x', 'y', 'z', 'qx', 'qy', 'qz', 'qw']
    buffer = Buffer.from_bag(path)
    edges = {e.frame: e for e in buffer.edges()}
    low = max(edges['odom'].oldest, edges['base_link'].oldest)
    high = min(edges['odom'].newest, edges['base_link'].newest)
    assert track['t'][0] == low and track['t'][-1] == high
    assert np.all(np.diff(track['t']) > 0)
    assert not np.isnan(track['x']).any()
    norms = np.sqrt(track['qx'] ** 2 + track['qy'] ** 2 + track['qz'] ** 2 + track['qw'] ** 2)
    np.testing.assert_allclose(norms, 1.0, atol=TOL)
    i = len(track['t']) // 2
    one = buffer.lookup_transform('map', 'base_footprint', int(track['t'][i])).transform
    assert (one.translation.x, one.rotation.w) == pytest.approx(
        (track['x'][i], track['qw'][i]), abs=TOL
    )
    # the robot drove somewhere
    assert math.hypot(track['x'][-1] - track['x'][0], track['y'][-1] - track['y'][0]) > 1.0
    # given stamps, and a buffer reused
    some = trajectory(buffer, 'map', 'base_footprint', track['t'][::100])
    np.testing.assert_array_equal(some['x'], track['x'][::100])


@pytest.mark.parametrize('name', ['ros2/tf_franka_db3', 'ros1/tf_franka.bag'])
def test_arm_with_static_frames_from_two_publishers(testdata: Path, name: str) -> None:
    buffer = Buffer.from_bag(testdata / name)
    edges = {e.frame: e for e in buffer.edges()}
    assert edges['panda_link0'].static and edges['panda_link0'].parent == 'world'
    assert edges['panda_hand'].static and edges['panda_link1'].length == 110
    # two /tf_static messages from two publishers (the ROS 1 bag keeps them apart as two
    # connections, its ROS 2 conversion has one): the second adds to the first
    assert sum(e.static for e in edges.values()) == 13
    static_publishers = {e.authority for e in edges.values() if e.static}
    if name.startswith('ros1'):  # named by the connection headers' callerid, as view_frames does
        assert static_publishers == {'/robot_state_publisher', '/virtual_joint_broadcaster_0'}
        assert edges['panda_leftfinger'].authority == '/robot_state_publisher'  # /tf
    else:  # ROS 2 records no publisher: the topic and connection stand for it
        assert static_publishers == {'/tf_static (connection 1 of tf_franka_db3)'}
    track = trajectory(buffer, 'world', 'panda_hand_tcp')
    assert len(track['t']) == 110 and not np.isnan(track['x']).any()


def test_ros1_and_ros2_versions_of_a_recording_agree(testdata: Path) -> None:
    ros1 = trajectory(testdata / 'ros1' / 'tf_example.bag', 'odom', 'base_link')
    ros2 = trajectory(testdata / 'ros2' / 'tf_example_db3', 'odom', 'base_link')
    assert len(ros1['t']) == 517
    for column in ros1:
        np.testing.assert_allclose(ros1[column], ros2[column], atol=TOL)
    franka1 = trajectory(testdata / 'ros1' / 'tf_franka.bag', 'world', 'panda_link7')
    franka2 = trajectory(testdata / 'ros2' / 'tf_franka_db3', 'world', 'panda_link7')
    for column in franka1:
        np.testing.assert_allclose(franka1[column], franka2[column], atol=TOL)


def test_from_bag_reads_only_the_tf_topics(testdata: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[object] = []
    original = Bag.raw_messages

    def spy(self: Bag, topics: object = None, *args: object) -> object:
        asked.append(topics)
        return original(self, topics, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(Bag, 'raw_messages', spy)
    Buffer.from_bag(testdata / 'ros2' / 'tf_nav2_mcap')
    assert asked == [['/tf', '/tf_static']]


def test_a_bag_without_tf_is_an_error(testdata: Path) -> None:
    with pytest.raises(BagError, match='no topic /tf or /tf_static in the recording; it has: '):
        Buffer.from_bag(testdata / 'ros2' / 'talker_mcap')


def write_ros1_tf_bag(path: Path) -> Path:
    """A ROS 1 bag of the old ``tf/tfMessage`` type, frame names with ROS 1's leading slash."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(
        get_types_from_msg('geometry_msgs/TransformStamped[] transforms', 'tf/msg/tfMessage')
    )
    T = store.types
    with Writer(path) as writer:
        connection = writer.add_connection('/tf', 'tf/msg/tfMessage', typestore=store)
        for i in range(20):
            stamp = T['builtin_interfaces/msg/Time'](sec=100 + i, nanosec=0)
            header = T['std_msgs/msg/Header'](seq=i, stamp=stamp, frame_id='/odom')
            angle = 0.1 * i
            transform = T['geometry_msgs/msg/Transform'](
                T['geometry_msgs/msg/Vector3'](float(i), 0.0, 0.0),
                T['geometry_msgs/msg/Quaternion'](
                    0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)
                ),
            )
            message = T['tf/msg/tfMessage'](
                [T['geometry_msgs/msg/TransformStamped'](header, '/base_link', transform)]
            )
            writer.write(
                connection, (100 + i) * 10**9, store.serialize_ros1(message, 'tf/msg/tfMessage')
            )
    return path


def test_ros1_tf_messages(tmp_path: Path) -> None:
    path = write_ros1_tf_bag(tmp_path / 'old_tf.bag')
    buffer = Buffer.from_bag(path)
    assert buffer.all_frames_as_string() == 'Frame base_link exists with parent odom.\n'
    t = buffer.lookup_transform('odom', 'base_link', 1005 * 10**8).transform
    assert t.translation.x == pytest.approx(0.5, abs=TOL)
    assert t.rotation.z == pytest.approx(math.sin(0.025), abs=TOL)
    with pytest.raises(ExtrapolationException, match='into the future'):
        buffer.lookup_transforms('odom', 'base_link', [200 * 10**9], strict=True)


def tf(x: float, sec: int) -> bytes:
    """A TFMessage's CDR: base_link at ``x`` in odom, stamped ``sec``."""
    from zros.cdr import encode, new_message

    stamped = {
        'header': {'stamp': {'sec': sec}, 'frame_id': 'odom'},
        'child_frame_id': 'base_link',
        'transform': {'translation': {'x': x}, 'rotation': {'w': 1.0}},
    }
    return encode(new_message('tf2_msgs/msg/TFMessage', transforms=[stamped]))


def test_a_damaged_tf_message_is_skipped_and_counted(tmp_path: Path) -> None:
    from tests.bag.makebags import make_db3

    rows = [
        (0, 10**9, tf(1.0, 1)),
        (0, 2 * 10**9, b'\x00\x01\x00\x00garbage'),
        (0, 3 * 10**9, tf(3.0, 3)),
    ]
    path = make_db3(tmp_path / 'tf.db3', [('/tf', 'tf2_msgs/msg/TFMessage')], rows)
    with Bag(path) as bag:
        buffer = Buffer.from_bag(bag)
        [skipped] = bag.skipped
    assert (skipped.topic, skipped.row, skipped.lost) == ('/tf', 2, 1)
    t = buffer.lookup_transform('odom', 'base_link', 2 * 10**9).transform
    assert t.translation.x == pytest.approx(2.0, abs=TOL)  # between the two intact messages


def test_a_recording_whose_clock_restarts_is_told(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Two runs of a simulation in one bag (sim time restarts): the buffer merges them stamp by
    stamp, which an analyst must hear of."""
    import logging

    from tests.bag.makebags import make_db3

    first = [(0, (1 + i) * 10**9, tf(float(i), i)) for i in range(5)]
    second = [(0, (10 + i) * 10**9, tf(-float(i), i)) for i in range(5)]  # the clock again at 0
    path = make_db3(tmp_path / 'two_runs.db3', [('/tf', 'tf2_msgs/msg/TFMessage')], first + second)
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        Buffer.from_bag(path)
    [told] = [r.getMessage() for r in caplog.records if 'restarted' in r.getMessage()]
    assert 'base_link (parent odom) go back 4.0 s after their 5-th, 1 time(s)' in told
    caplog.clear()
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        Buffer.from_bag(make_db3(tmp_path / 'one.db3', [('/tf', 'tf2_msgs/msg/TFMessage')], first))
    assert 'restarted' not in caplog.text


def test_the_trajectory_of_a_static_chain_is_one_row_at_time_0() -> None:
    """tf2_echo shows a static chain "At time 0.0"; zero rows said nothing."""
    buffer = Buffer(cache_time=None)
    one = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    buffer.add('base', 'arm', 0, one, 'urdf', static=True)
    buffer.add('arm', 'hand', 0, one, 'urdf', static=True)
    columns = trajectory(buffer, 'base', 'hand')
    assert columns['t'].tolist() == [0] and columns['x'].tolist() == [2.0]
    buffer.add('world', 'cart', 5, one, 'odometry')  # moving, but never at the same time
    buffer.add('cart', 'pole', 9, one, 'odometry')
    with pytest.raises(ExtrapolationException, match='no instant is covered by every moving'):
        trajectory(buffer, 'world', 'pole')


def test_bad_transforms_in_a_recording_are_refused_one_by_one(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """The checks of a live buffer, on a recording: each bad transform is counted, told once
    per sender, and the good ones of the same edge stay (a quaternion off by less than tf2's
    tolerance is normalised)."""
    import logging

    from tests.bag.makebags import make_db3
    from zros.cdr import encode, new_message

    def message(*transforms: tuple[str, str, int, tuple[float, ...]]) -> bytes:
        stamped = [
            {
                'header': {'stamp': {'sec': sec}, 'frame_id': parent},
                'child_frame_id': child,
                'transform': {
                    'translation': dict(zip('xyz', pose[:3], strict=True)),
                    'rotation': dict(zip('xyzw', pose[3:], strict=True)),
                },
            }
            for parent, child, sec, pose in transforms
        ]
        return encode(new_message('tf2_msgs/msg/TFMessage', transforms=stamped))

    good = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    rounded = (2.0, 0.0, 0.0, 0.0, 0.0, 0.7071, 0.7071)
    rows = [
        (0, 1 * S, message(('odom', 'base', 1, good), ('odom', 'odom', 1, good))),
        (0, 2 * S, message(('odom', 'base', 2, (math.nan, 0, 0, 0, 0, 0, 1)))),
        (0, 3 * S, message(('odom', 'base', 3, (0, 0, 0, 0, 0, 0, 0.5)), ('', 'arm', 3, good))),
        (0, 4 * S, message(('odom', 'base', 4, rounded), ('odom', 'odom', 4, good))),
    ]
    path = make_db3(tmp_path / 'bad.db3', [('/tf', 'tf2_msgs/msg/TFMessage')], rows)
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        buffer = Buffer.from_bag(path)
    assert buffer.rejections.counts == {
        'TF_SELF_TRANSFORM': 2,
        'TF_NAN_INPUT': 1,
        'TF_DENORMALIZED_QUATERNION': 1,
        'TF_NO_FRAME_ID': 1,
    }
    told = [r.getMessage() for r in caplog.records if r.name == 'zros.tf']
    assert len(told) == 4 and sum('TF_SELF_TRANSFORM' in line for line in told) == 1
    assert (buffer.stamps('odom', 'base') // S).tolist() == [1, 4]
    t = buffer.lookup_transform('odom', 'base', 4 * S).transform
    assert (t.translation.x, t.rotation.z) == pytest.approx((2.0, math.sqrt(0.5)))
