"""``zros foxglove`` in front of real ROS 2 (rclpy) behind a bridge: a Foxglove client gets and
sets an rclpy node's parameters (``/node.name``, as foxglove_bridge names them), receives the
bytes an rclpy publisher sent, and publishes to an rclpy subscription."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip(
    'rclpy.parameter_client',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)
pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

import zros
from tests.gateway.foxglove.client import FoxgloveClient
from tests.gateway.node_process import require
from tests.interop.conftest import Interop
from zros.gateway.foxglove.server import serve
from zros.testing import wait_for

TIMEOUT = 20.0
#: rcl_interfaces ParameterType numbers
INTEGER, DOUBLE, STRING, DOUBLE_ARRAY = 2, 3, 4, 8


@pytest.fixture
def foxglove(interop: Interop) -> Iterator[tuple[Any, FoxgloveClient]]:
    """A gateway on its own zros node at the bridge, and a Foxglove client of it."""
    require()
    server = serve(node=interop.node('zros_foxglove'), port=0, sim_time=False)
    client = FoxgloveClient(server.url)
    yield server, client
    client.close()
    server.close()


def test_foxglove_gets_and_sets_rclpy_parameters(
    interop: Interop, foxglove: tuple[Any, FoxgloveClient]
) -> None:
    ros = interop.ros.worker
    node_name = interop.topic('fox_params')[1:]
    spec = [
        {
            'name': 'gain',
            'type': DOUBLE,
            'value': 0.5,
            'descriptor': {'floating_point_range': [0.0, 1.0, 0.0]},
        },
        {'name': 'count', 'type': INTEGER, 'value': 4},
        {'name': 'label', 'type': STRING, 'value': 'arm'},
        {'name': 'weights', 'type': DOUBLE_ARRAY, 'value': [0.25, 2.0]},
    ]
    handle, fqn = ros.param_node(node_name, spec)
    try:
        _, client = foxglove
        found: dict[str, Any] = {}

        def listed() -> bool:  # once the node's parameter services crossed the bridge
            found.update({p['name']: p for p in client.get_parameters([])})
            return f'{fqn}.gain' in found

        assert wait_for(listed, TIMEOUT)
        assert found[f'{fqn}.gain'] == {'name': f'{fqn}.gain', 'value': 0.5, 'type': 'float64'}
        assert found[f'{fqn}.count']['value'] == 4
        assert found[f'{fqn}.label']['value'] == 'arm'
        assert found[f'{fqn}.weights'] == {
            'name': f'{fqn}.weights',
            'value': [0.25, 2],
            'type': 'float64_array',
        }
        assert [p['value'] for p in client.get_parameters([f'{fqn}.count'])] == [4]

        updated = client.set_parameters(
            [
                {'name': f'{fqn}.gain', 'value': 1, 'type': 'float64'},  # a whole float
                {'name': f'{fqn}.label', 'value': 'gripper'},
            ]
        )
        assert {p['name']: p['value'] for p in updated} == {
            f'{fqn}.gain': 1,
            f'{fqn}.label': 'gripper',
        }
        checker, ready = ros.param_client(fqn, TIMEOUT)
        assert ready
        values = ros.param_call(checker, 'get', TIMEOUT, names=['gain', 'label'])['values']
        assert values == [{'type': DOUBLE, 'value': 1.0}, {'type': STRING, 'value': 'gripper'}]
        start = client.mark()
        refused = client.set_parameters([{'name': f'{fqn}.gain', 'value': 3.5, 'type': 'float64'}])
        assert refused == [{'name': f'{fqn}.gain', 'value': 1, 'type': 'float64'}]
        client.wait(
            lambda e: e['ev'] == 'status' and f'{fqn} refused gain' in e['status']['message'],
            start=start,
        )
        ros.destroy(checker)
    finally:
        ros.destroy(handle)


def test_foxglove_gets_the_bytes_rclpy_published(
    interop: Interop, foxglove: tuple[Any, FoxgloveClient]
) -> None:
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String

    topic = interop.topic('fox_chatter')
    publisher = interop.ros.publisher(topic, 'std_msgs/msg/String')
    _, client = foxglove
    subscription = client.subscribe(topic, TIMEOUT)
    assert interop.ros.wait_subscribers(publisher, timeout=TIMEOUT) >= 1
    sent = [bytes(serialize_message(String(data=f'from rclpy {i}'))) for i in range(3)]
    interop.ros.publish(publisher, sent)
    # as DDS carried them: Fast DDS pads a serialized payload to a multiple of 4 bytes
    padded = [data + bytes(-len(data) % 4) for data in sent]
    assert client.wait_messages(subscription, 3, TIMEOUT) == padded


def test_foxglove_publishes_to_rclpy(
    interop: Interop, foxglove: tuple[Any, FoxgloveClient]
) -> None:
    topic = interop.topic('fox_cmd_vel')
    subscription = interop.ros.subscription(topic, 'geometry_msgs/msg/Twist')
    _, client = foxglove
    channel = client.advertise(topic, 'json', 'geometry_msgs/msg/Twist')
    expected = zros.Message('geometry_msgs/msg/Twist', linear={'x': 0.5}, angular={'z': 1.0})
    received: list[bytes] = []

    def arrived() -> bool:  # publish until the route through the bridge carries it
        client.publish(channel, b'{"linear": {"x": 0.5}, "angular": {"z": 1.0}}')
        received.extend(interop.ros.wait_messages(subscription, 1, timeout=0.2))
        return bool(received)

    assert wait_for(arrived, TIMEOUT)
    assert received[0] == expected.serialize()
