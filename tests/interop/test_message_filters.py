"""rclpy publishes two topics; a zros ApproximateTimeSynchronizer pairs them (through the bridge
stand-in in its network namespace, as the other interop tests)."""

from __future__ import annotations

from typing import Any

import pytest

pytest.importorskip(
    'rclpy.serialization',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)

from rclpy.serialization import serialize_message

import zros
from tests.interop import rig
from tests.interop.conftest import Interop
from tests.interop.rclpy_support import make_registry, to_rclpy
from zros.message_filters import ApproximateTimeSynchronizer, Subscriber
from zros.testing import wait_for

POINT = 'geometry_msgs/msg/PointStamped'
REGISTRY = make_registry()
SECOND = 1_000_000_000


def rclpy_point(stamp_ns: int, x: float) -> bytes:
    """What an rclpy publisher of a PointStamped sends (rosidl serialization)."""
    message: Any = REGISTRY.get_class(POINT)()
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, SECOND)
    message.point.x = x
    return bytes(serialize_message(to_rclpy(REGISTRY, POINT, message)))


def test_rclpy_topics_into_an_approximate_time_synchronizer(interop: Interop) -> None:
    node = interop.node('fusion')
    topics = interop.topic('left'), interop.topic('right')
    left, right = (Subscriber(node, POINT, topic) for topic in topics)
    sync = ApproximateTimeSynchronizer([left, right], queue_size=10, slop=0.05)
    pairs: list[tuple[float, float]] = []
    sync.registerCallback(lambda a, b: pairs.append((a.point.x, b.point.x)))
    publishers = [interop.ros.publisher(topic, POINT) for topic in topics]
    for publisher in publishers:
        assert interop.ros.wait_subscribers(publisher, timeout=rig.DEADLINE) >= 1
    # 10 and 20 ms apart: pairs; the last right message has no partner within 50 ms
    interop.ros.publish(publishers[0], [rclpy_point(1 * SECOND, 1.0), rclpy_point(2 * SECOND, 2.0)])
    interop.ros.publish(
        publishers[1],
        [
            rclpy_point(1 * SECOND + 10_000_000, 1.01),
            rclpy_point(2 * SECOND + 20_000_000, 2.02),
            rclpy_point(5 * SECOND, 5.0),
        ],
    )
    assert wait_for(
        lambda: node.spin_once(0.05) >= 0 and right.sub.received == 3 and len(pairs) >= 2,
        rig.DEADLINE,
    ), (pairs, interop.standin_log())
    node.spin_once(0)
    assert sorted(pairs) == [(1.0, 1.01), (2.0, 2.02)]
    assert isinstance(left.sub, zros.Subscriber)
