"""A type zros has no definition of, published by rclpy behind the bridge: zros asks ROS.

rclpy nodes (Jazzy) serve ``~/get_type_description``; the bridge routes it like any service.
``zros topic echo`` does what this test does through ``zros.cli.shared.known_type``.
"""

from __future__ import annotations

import pytest

pytest.importorskip(
    'rclpy', reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable'
)

from rclpy.serialization import serialize_message

from tests.interop import rig
from tests.interop.conftest import Interop
from tests.interop.rclpy_support import make_registry, to_rclpy
from zros.cdr.registry import TypeRegistry
from zros.cli.shared import known_type

TIMEOUT = 30.0
NAME = 'test_msgs/msg/BasicTypes'  # in the wheels, not in the rosbags typestore


def test_zros_learns_an_rclpy_publishers_type(interop: Interop) -> None:
    known = make_registry()
    message = known.get_class(NAME)(int32_value=-7, float64_value=2.5, bool_value=True)
    topic = interop.topic('basic')
    publisher = interop.ros.publisher(topic, NAME, rig.qos_spec(10))
    node = interop.node('cli', registry=TypeRegistry('jazzy', paths=[], ament=False))
    assert node.registry.find(NAME) is None
    assert node.graph.wait_until(lambda: node.count_publishers(topic) > 0, TIMEOUT)
    assert known_type(node, topic, NAME) == NAME
    learned = node.registry.definition(NAME)
    assert [f.name for f in learned.fields] == [f.name for f in known.definition(NAME).fields]
    subscription = node.create_subscription(NAME, topic)
    data = bytes(serialize_message(to_rclpy(known, NAME, message)))
    received = None
    for _ in range(20):  # the bridge routes data once it sees the subscription
        interop.ros.publish(publisher, [data])
        received = subscription.wait_for_message(1.0)
        if received is not None:
            break
    assert received is not None
    assert received.int32_value == -7 and received.float64_value == 2.5
