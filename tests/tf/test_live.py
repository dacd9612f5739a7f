"""The listener and the broadcasters between zros nodes on both wires: dynamic and latched
static transforms (a listener started afterwards), remapping, bad data from the network,
waiting lookups and transforming messages."""

from __future__ import annotations

import asyncio
import logging
import math
import threading
from collections.abc import Callable

import numpy as np
import pytest

import zros
from zros.cdr import Message
from zros.node import Node
from zros.runtime.signal import clear_interrupt, interrupt
from zros.testing import wait_for
from zros.tf import (
    Buffer,
    ExtrapolationException,
    LookupException,
    StaticTransformBroadcaster,
    StaticTransformListener,
    TransformBroadcaster,
    TransformListener,
)

TOL = 1e-9


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module that makes nodes runs on both wire schemes."""
    return str(request.param)


def stamped(
    parent: str, child: str, stamp: int, xyz: tuple[float, float, float], yaw: float = 0.0
) -> Message:
    t = zros.Message('geometry_msgs/msg/TransformStamped')
    t.header.frame_id = parent
    t.header.stamp = zros.Time(stamp).to_msg()
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    t.transform.rotation.z = math.sin(yaw / 2)
    t.transform.rotation.w = math.cos(yaw / 2)
    return t


def test_latched_static_and_dynamic_transforms_reach_a_listener_started_afterwards(
    zros_node: Callable[..., Node],
) -> None:
    talker = zros_node('robot_state_publisher')
    static = StaticTransformBroadcaster(talker)
    static.send_transform(stamped('base_link', 'laser', 0, (0.2, 0.0, 0.3)))
    static.send_transform([stamped('base_link', 'camera', 0, (0.1, 0.0, 0.5))])  # adds
    dynamic = TransformBroadcaster(talker)

    buffer = Buffer()
    listener = TransformListener(buffer, zros_node('listener'))
    assert wait_for(lambda: {'laser', 'camera'} <= buffer.frames(), 10)
    assert dynamic.publisher.wait_for_subscribers()
    for i in range(5):
        dynamic.send_transform(stamped('odom', 'base_link', (i + 1) * 10**9, (i, 0.0, 0.0)))
    # no spinning: the listener fills the buffer as samples arrive
    t = buffer.lookup_transform('odom', 'laser', 35 * 10**8, timeout=10.0)
    tr = t.transform.translation
    assert (tr.x, tr.y, tr.z) == pytest.approx((2.7, 0.0, 0.3), abs=TOL)
    assert buffer.can_transform('odom', 'camera', 5 * 10**9, timeout=10.0)
    assert buffer.lookup_transform('odom', 'camera', 0).header.stamp.sec == 5
    edges = {e.frame: e for e in buffer.edges()}
    assert edges['laser'].static and not edges['base_link'].static
    # the publisher as the graph names it (a sample can overtake its announcement: the
    # listener asks the graph again for later ones)
    stamps = iter(range(6 * 10**9, 10**12, 10**9))

    def named() -> bool:
        dynamic.send_transform(stamped('odom', 'base_link', next(stamps), (0.0, 0.0, 0.0)))
        return 'robot_state_publisher' in buffer.edges()[0].authority

    assert wait_for(named, 10), buffer.edges()[0]
    listener.unregister()


def test_static_broadcaster_replaces_a_child_frame_it_holds(zros_node: Callable[..., Node]) -> None:
    talker = zros_node('talker')
    static = StaticTransformBroadcaster(talker)
    static.send_transform(stamped('base', 'arm', 0, (1.0, 0.0, 0.0)))
    static.send_transform(stamped('base', 'arm', 0, (2.0, 0.0, 0.0)))
    static.send_transform(stamped('base', 'head', 0, (0.0, 0.0, 1.0)))
    buffer = Buffer()
    TransformListener(buffer, zros_node('listener'))
    assert wait_for(lambda: buffer.can_transform('base', 'head', 0), 10)
    assert buffer.lookup_transform('base', 'arm', 0).transform.translation.x == 2.0


def test_remapped_tf_topics(zros_node: Callable[..., Node]) -> None:
    talker = zros_node('talker', remap=['/tf:=/robot1/tf', '/tf_static:=/robot1/tf_static'])
    StaticTransformBroadcaster(talker).send_transform(stamped('a', 'b', 0, (1.0, 0.0, 0.0)))
    other = StaticTransformBroadcaster(zros_node('other'))
    other.send_transform(stamped('a', 'c', 0, (1.0, 0.0, 0.0)))  # on /tf_static
    buffer = Buffer()
    listener = TransformListener(
        buffer, zros_node('listener', remap=['/tf_static:=/robot1/tf_static'])
    )
    assert listener.topics == ('/tf', '/robot1/tf_static')
    assert wait_for(lambda: 'b' in buffer.frames(), 10)
    everything = Buffer()
    TransformListener(everything, zros_node('plain'))
    assert wait_for(lambda: 'c' in everything.frames(), 10)
    assert 'c' not in buffer.frames() and 'b' not in everything.frames()


def test_bad_data_from_the_network_is_dropped_and_told_once(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture, zros_wire: str
) -> None:
    talker = zros_node('bad_talker')
    broadcaster = TransformBroadcaster(talker)
    buffer = Buffer()
    TransformListener(buffer, zros_node('listener'))
    assert broadcaster.publisher.wait_for_subscribers()
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        if zros_wire == 'bridge':  # under rmw_zenoh the key carries the type: no match
            garbage = zros.Publisher('/tf', 'std_msgs/msg/String', node=zros_node('garbage'))
            assert garbage.wait_for_subscribers()
            for _ in range(3):
                garbage.write(zros.Message('std_msgs/msg/String', data='not a transform'))
            assert wait_for(lambda: buffer.rejections.counts['TF_UNDECODABLE'] == 3)
        for i in range(10):
            stamp = (i + 1) * 10**9
            broadcaster.send_transform(
                [
                    stamped('a', 'a', stamp, (0.0, 0.0, 0.0)),
                    stamped('a', 'b', stamp, (math.nan, 0.0, 0.0)),
                    stamped('a', 'c', stamp, (1.0, 0.0, 0.0)),
                ]
            )
            # one at a time: /tf drops on a full queue (as under rmw_zenoh), and a burst of ten
            # on a loaded machine may lose one, which is not what this test is about
            assert wait_for(lambda s=stamp: buffer.can_transform('a', 'c', s), 10)
    counts = buffer.rejections.counts
    assert counts['TF_SELF_TRANSFORM'] == 10 and counts['TF_NAN_INPUT'] == 10
    told = [r.getMessage() for r in caplog.records if r.name == 'zros.tf']
    assert sum('TF_SELF_TRANSFORM' in line for line in told) == 1
    assert sum('TF_NAN_INPUT' in line for line in told) == 1
    assert sum('does not decode as tf2_msgs/msg/TFMessage' in line for line in told) == (
        zros_wire == 'bridge'
    )
    assert buffer.frames() == {'a', 'c'}


def test_transform_stamped_messages(zros_node: Callable[..., Node]) -> None:
    buffer = Buffer()
    yaw = math.pi / 2
    buffer.add(
        'map', 'base', 10**9, (1.0, 2.0, 0.0, 0, 0, math.sin(yaw / 2), math.cos(yaw / 2)), 'test'
    )
    stamp = zros.Time(10**9).to_msg()

    point = zros.Message('geometry_msgs/msg/PointStamped')
    point.header.frame_id, point.header.stamp = 'base', stamp
    point.point.x = 1.0
    moved = buffer.transform(point, 'map')
    assert moved.header.frame_id == 'map' and point.header.frame_id == 'base'
    latest = point.copy()
    latest.header.stamp = zros.Time(0).to_msg()  # the latest: the answer says which time
    assert buffer.transform(latest, 'map').header.stamp == stamp
    assert latest.header.stamp.sec == 0  # the input is left alone
    assert (moved.point.x, moved.point.y, moved.point.z) == pytest.approx((1.0, 3.0, 0.0), abs=TOL)

    vector = zros.Message('geometry_msgs/msg/Vector3Stamped')
    vector.header.frame_id, vector.header.stamp = 'base', stamp
    vector.vector.x = 1.0
    turned = buffer.transform(vector, 'map').vector
    assert (turned.x, turned.y, turned.z) == pytest.approx((0.0, 1.0, 0.0), abs=TOL)  # no shift

    pose = zros.Message('geometry_msgs/msg/PoseStamped')
    pose.header.frame_id, pose.header.stamp = 'base', stamp
    pose.pose.position.x = 1.0
    placed = buffer.transform(pose, 'map').pose
    assert (placed.position.x, placed.position.y) == pytest.approx((1.0, 3.0), abs=TOL)
    assert placed.orientation.z == pytest.approx(math.sin(yaw / 2), abs=TOL)

    covariant = zros.Message('geometry_msgs/msg/PoseWithCovarianceStamped')
    covariant.header.frame_id, covariant.header.stamp = 'base', stamp
    covariance = np.zeros((6, 6))
    covariance[0, 0], covariance[1, 1], covariance[5, 5] = 4.0, 1.0, 0.5  # x uncertain
    covariant.pose.covariance = covariance.reshape(36)
    rotated = np.asarray(buffer.transform(covariant, 'map').pose.covariance).reshape(6, 6)
    assert rotated[0, 0] == pytest.approx(1.0, abs=TOL)  # base's x is map's y after 90 deg
    assert rotated[1, 1] == pytest.approx(4.0, abs=TOL)
    assert rotated[5, 5] == pytest.approx(0.5, abs=TOL)

    with pytest.raises(zros.ZrosError, match='cannot transform a'):
        other = zros.Message('geometry_msgs/msg/TwistStamped')
        other.header.frame_id, other.header.stamp = 'base', stamp
        buffer.transform(other, 'map')
    with pytest.raises(ExtrapolationException):
        point.header.stamp = zros.Time(2 * 10**9).to_msg()
        buffer.transform(point, 'map')

    points = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    np.testing.assert_allclose(
        buffer.transform_points(points, 'map', 'base', 10**9), [[1, 3, 0], [0, 2, 0]], atol=TOL
    )
    with pytest.raises(zros.ZrosError, match=r'shape \(N, 3\)'):
        buffer.transform_points(np.zeros((2, 2)), 'map', 'base', 10**9)


def test_a_waiting_lookup_ends_at_once_on_ctrl_c() -> None:
    buffer = Buffer()
    timer = threading.Timer(0.2, interrupt)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            buffer.lookup_transform('map', 'base', 0, timeout=30.0)
    finally:
        timer.cancel()
        clear_interrupt()


def test_a_waiting_lookup_returns_when_the_data_arrives() -> None:
    buffer = Buffer()
    t = stamped('map', 'base', 10**9, (1.0, 0.0, 0.0))
    timer = threading.Timer(0.1, buffer.set_transform, (t, 'late'))
    timer.start()
    got = buffer.lookup_transform('map', 'base', 0, timeout=10.0)
    assert got.transform.translation.x == 1.0
    with pytest.raises(LookupException):
        buffer.lookup_transform('map', 'nowhere', 0, timeout=0.05)


def test_the_buffer_clears_when_sim_time_jumps_back(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    """A bag played in a loop with /clock: sim time restarts and so do the stamps. tf2_ros
    clears the buffer (statics stay); without that every new transform is old data for ever."""
    second = 10**9
    viewer = zros_node('viewer', use_sim_time=True)
    player = zros_node('player')
    clock = player.create_publisher('rosgraph_msgs/msg/Clock', '/clock')
    assert clock.wait_for_subscribers()

    def move_to(seconds: int) -> None:
        stamp = zros.Time(seconds * second)
        clock.write(zros.Message('rosgraph_msgs/msg/Clock', clock=stamp.to_msg()))
        assert wait_for(lambda: viewer.now() == stamp)

    buffer = Buffer()
    listener = TransformListener(buffer, viewer)
    StaticTransformBroadcaster(player).send_transform(stamped('base', 'laser', 0, (0.2, 0, 0)))
    odometry = TransformBroadcaster(player)
    assert odometry.publisher.wait_for_subscribers()
    move_to(100)
    odometry.send_transform(stamped('odom', 'base', 100 * second, (5.0, 0, 0)))
    assert buffer.can_transform('odom', 'laser', 100 * second, timeout=10.0)
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        move_to(10)  # the loop starts again
        odometry.send_transform(stamped('odom', 'base', 10 * second, (1.0, 0, 0)))
        assert buffer.can_transform('odom', 'laser', 10 * second, timeout=10.0)
    found = buffer.lookup_transform('odom', 'laser', 0).transform.translation
    assert (found.x, found.y) == pytest.approx((1.2, 0.0))  # the static edge stayed
    assert 'Detected jump back in time. Clearing tf buffer.' in caplog.text
    assert buffer.rejections.counts['TF_OLD_DATA'] == 0
    listener.unregister()


def test_rclpy_style_arguments(zros_node: Callable[..., Node]) -> None:
    """What an rclpy user writes: ``Buffer(node=node)``, ``TransformListener(buffer, node,
    spin_thread=True, qos=10)``, ``can_transform(..., return_debug_tuple=True)``."""
    node = zros_node('rclpy_user')
    buffer = Buffer(node=node)
    listener = TransformListener(buffer, node, spin_thread=True, qos=10, static_qos='latched')
    TransformBroadcaster(node, 10).send_transform(stamped('odom', 'base', 10**9, (1.0, 0, 0)))
    assert buffer.can_transform('odom', 'base', 10**9, timeout=10.0)
    assert buffer.can_transform('odom', 'base', 10**9, return_debug_tuple=True) == (True, '')
    found, why = buffer.can_transform('odom', 'bsae', 10**9, return_debug_tuple=True)
    assert not found and 'base' in why  # the closest frame's name
    both = buffer.can_transform_full('odom', 10**9, 'base', 10**9, 'odom', return_debug_tuple=True)
    assert both == (True, '')
    with pytest.raises(ValueError, match='unknown QoS preset'):
        TransformListener(buffer, node, qos='fast')
    listener.unregister()


def test_static_only_listeners(zros_node: Callable[..., Node]) -> None:
    """rclpy's StaticTransformListener, and TransformListener(static_only=True, tf_topic=...)."""
    talker = zros_node('robot')
    StaticTransformBroadcaster(talker).send_transform(stamped('base', 'laser', 0, (0.2, 0, 0)))
    moving = TransformBroadcaster(talker)
    fixed = Buffer()
    static_listener = StaticTransformListener(fixed, zros_node('fixed_frames'))
    assert static_listener.topics == ('/tf_static',)
    everything = Buffer()
    listener = TransformListener(everything, zros_node('all_frames'), tf_topic='/robot/tf')
    assert listener.topics == ('/robot/tf', '/tf_static')
    assert wait_for(lambda: 'laser' in fixed.frames() and 'laser' in everything.frames(), 10)
    assert not moving.publisher.wait_for_subscribers(0.5)  # nobody listens to /tf
    renamed = TransformBroadcaster(zros_node('renamed', remap=['/tf:=/robot/tf']))
    assert renamed.publisher.wait_for_subscribers()
    moving.send_transform(stamped('odom', 'base', 10**9, (1.0, 0, 0)))  # on /tf: nobody
    renamed.send_transform(stamped('odom', 'base', 2 * 10**9, (2.0, 0, 0)))  # on /robot/tf
    found = everything.lookup_transform('odom', 'laser', 0, timeout=10.0).transform.translation
    assert found.x == pytest.approx(2.2)
    assert everything.lookup_transform('odom', 'base', 0).header.stamp.sec == 2  # not /tf's
    assert 'odom' not in fixed.frames()
    static_listener.unregister()
    listener.unregister()


def test_waiting_for_a_transform_without_blocking() -> None:
    """rclpy's wait_for_transform_async and lookup_transform_async (and the _full ones)."""
    buffer = Buffer()
    future = buffer.wait_for_transform_async('map', 'base', 10**9)
    full = buffer.wait_for_transform_full_async('map', 10**9, 'base', 10**9, 'map')
    assert not future.done() and not full.done()
    buffer.set_transform(stamped('map', 'odom', 10**9, (1.0, 0, 0)), 'slam')
    assert not future.done()  # map -> base is not there yet
    buffer.set_transform(stamped('odom', 'base', 10**9, (2.0, 0, 0)), 'odometry')
    assert future.result(0).transform.translation.x == 3.0
    assert full.result(0).child_frame_id == 'base'
    assert buffer.wait_for_transform_async('map', 'base', 0).result(0).header.stamp.sec == 1
    with pytest.raises(zros.ZrosError, match='empty'):
        buffer.wait_for_transform_async('', 'base', 0).result(0)  # a bad argument: at once
    assert not buffer._watchers

    async def main() -> tuple[Message, Message]:
        waiting = asyncio.ensure_future(buffer.lookup_transform_async('map', 'arm', 2 * 10**9))
        also = asyncio.ensure_future(
            buffer.lookup_transform_full_async('map', 2 * 10**9, 'arm', 2 * 10**9, 'map')
        )
        await asyncio.sleep(0)
        assert not waiting.done()
        buffer.set_transform(stamped('map', 'odom', 2 * 10**9, (1.0, 0, 0)), 'slam')
        buffer.set_transform(stamped('odom', 'base', 2 * 10**9, (2.0, 0, 0)), 'odometry')
        buffer.set_transform_static(stamped('base', 'arm', 0, (0.5, 0, 0)), 'urdf')
        return await asyncio.wait_for(waiting, 10), await asyncio.wait_for(also, 10)

    first, second = asyncio.run(main())
    assert first.transform.translation.x == second.transform.translation.x == 3.5


def test_an_async_wait_fails_on_ctrl_c() -> None:
    buffer = Buffer()
    future = buffer.wait_for_transform_async('map', 'base', 0)
    try:
        interrupt()
        with pytest.raises(KeyboardInterrupt):
            future.result(10)
        buffer.set_transform(stamped('map', 'base', 10**9, (1.0, 0, 0)), 'late')
        assert not buffer._watchers
    finally:
        clear_interrupt()


def test_transform_full_carries_a_message_through_time() -> None:
    """A point seen 1 m ahead of the robot at 1 s, where the robot is at 2 s after driving
    1 m: at its own origin (through odom, which does not move)."""
    buffer = Buffer()
    buffer.set_transform(stamped('odom', 'base', 10**9, (0.0, 0, 0)), 'odometry')
    buffer.set_transform(stamped('odom', 'base', 2 * 10**9, (1.0, 0, 0)), 'odometry')
    point = zros.Message('geometry_msgs/msg/PointStamped')
    point.header.frame_id, point.header.stamp = 'base', zros.Time(10**9).to_msg()
    point.point.x = 1.0
    then = buffer.transform_full(point, 'base', 2 * 10**9, 'odom')
    assert (then.point.x, then.point.y) == pytest.approx((0.0, 0.0), abs=TOL)
    assert then.header.frame_id == 'base' and then.header.stamp.sec == 2
    with pytest.raises(ExtrapolationException):
        buffer.transform_full(point, 'base', 3 * 10**9, 'odom')


def test_a_listeners_on_message_sees_each_message_and_may_fail(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    seen: list[tuple[int, str, bool]] = []

    def on_message(message: Message, authority: object, static: bool) -> None:
        seen.append((len(message.transforms), str(authority), static))
        raise RuntimeError('a bug in the callback')

    buffer = Buffer()
    listener = TransformListener(buffer, zros_node('watcher'), on_message=on_message)
    broadcaster = TransformBroadcaster(zros_node('odometry'))
    assert broadcaster.publisher.wait_for_subscribers()
    with caplog.at_level(logging.ERROR, 'zros.tf'):
        broadcaster.send_transform(
            [stamped('odom', 'base', 10**9, (1.0, 0, 0)), stamped('base', 'arm', 10**9, (1, 0, 0))]
        )
        assert buffer.can_transform('odom', 'arm', 10**9, timeout=10.0)  # in despite the bug
        assert wait_for(lambda: 'a bug in the callback' in caplog.text, 10)
    assert seen[0][0] == 2 and seen[0][1] and not seen[0][2]  # the sender, named when shown
    listener.unregister()
