"""A type zros has no definition of, published by rclpy behind the bridge: zros asks ROS.

rclpy nodes (Jazzy) serve ``~/get_type_description``; the bridge routes it like any service.
``zros topic echo`` does what this test does through ``zros.cli.graph_lookup.known_type``.
"""

from __future__ import annotations

import pytest

pytest.importorskip(
    'rclpy', reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable'
)

from typing import Any

from rclpy.serialization import serialize_message

from tests.interop import rig
from tests.interop.conftest import Interop
from tests.interop.rclpy_support import SHARE, make_registry, to_rclpy
from zros.cdr.hashing import type_hash
from zros.cdr.registry import TypeRegistry
from zros.cli.graph_lookup import known_type
from zros.cli.shared import CommandError
from zros.services.typeinfo import SERVICE_TYPE
from zros.testing import wait_for

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

    def learned() -> bool:
        try:
            return known_type(node, topic, NAME) == NAME
        except CommandError:  # the graph showed the publisher before its node's service
            return False

    assert wait_for(learned, TIMEOUT)
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


STATUS = 'my_robot_msgs/msg/Status'


def test_rclpy_asks_a_zros_node_for_its_custom_type(interop: Interop) -> None:
    from rclpy.serialization import deserialize_message
    from type_description_interfaces.srv import GetTypeDescription

    registry = TypeRegistry('jazzy', paths=[SHARE], ament=False)
    registry.register_text(STATUS, 'string mode\nfloat64 battery\nint32[] errors\n')
    node = interop.node('custom_pub_td', registry=registry)
    node.create_publisher(STATUS, interop.topic('status'), 10)
    service = '/custom_pub_td/get_type_description'

    def ask(name: str, type_hash: str) -> Any:
        request = GetTypeDescription.Request(
            type_name=name, type_hash=type_hash, include_type_sources=True
        )
        reply = interop.ros.call_service(
            service, SERVICE_TYPE, bytes(serialize_message(request)), TIMEOUT
        )
        return deserialize_message(reply, GetTypeDescription.Response)

    described = ask(STATUS, type_hash(registry, STATUS))
    assert described.successful, described.failure_reason
    assert described.type_description.type_description.type_name == STATUS
    fields = described.type_description.type_description.fields
    assert [f.name for f in fields] == ['mode', 'battery', 'errors']
    assert [s.raw_file_contents for s in described.type_sources] == [
        'string mode\nfloat64 battery\nint32[] errors\n'
    ]
    refused = ask(STATUS, 'RIHS01_' + '0' * 64)
    assert not refused.successful and 'has the hash' in refused.failure_reason
