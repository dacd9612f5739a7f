"""``zros rosbridge`` in front of real ROS 2 (rclpy) behind a bridge: roslibpy (and roslibjs,
where node is) receive what an rclpy publisher sends, publish to an rclpy subscription and
call an rclpy service."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip(
    'rclpy.parameter_client',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)
pytest.importorskip('websockets', reason='the websockets library (the rosbridge extra) is missing')
pytest.importorskip('roslibpy', reason='roslibpy (the test extra) is missing')

import roslibpy

import zros
from tests.gateway.rosbridge.roslib_client import RoslibClient, require_roslib
from tests.interop.conftest import Interop
from zros.gateway.rosbridge.server import serve
from zros.testing import wait_for

TIMEOUT = 20.0


@pytest.fixture
def gateway(interop: Interop) -> Iterator[Any]:
    """A gateway on its own zros node at the bridge."""
    server = serve(node=interop.node('zros_rosbridge'), port=0)
    yield server
    server.close()


@pytest.fixture
def web(gateway: Any) -> Iterator[Any]:
    client = roslibpy.Ros('127.0.0.1', gateway.port, transport='asyncio')
    client.run(timeout=TIMEOUT)
    yield client
    client.close()
    wait_for(lambda: not client.is_connected, 5.0)
    client.terminate()


def test_roslibpy_gets_what_rclpy_publishes(interop: Interop, gateway: Any, web: Any) -> None:
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String

    topic = interop.topic('rb_chatter')
    publisher = interop.ros.publisher(topic, 'std_msgs/msg/String')
    received: list[dict[str, Any]] = []
    listener = roslibpy.Topic(web, topic, 'std_msgs/String')
    listener.subscribe(lambda message: received.append(dict(message)))
    assert interop.ros.wait_subscribers(publisher, timeout=TIMEOUT) >= 1

    def arrived() -> bool:
        data = bytes(serialize_message(String(data='from rclpy')))
        interop.ros.publish(publisher, [data])
        return bool(received)

    assert wait_for(arrived, TIMEOUT)
    assert received[0] == {'data': 'from rclpy'}


def test_roslibpy_publishes_to_rclpy(interop: Interop, gateway: Any, web: Any) -> None:
    topic = interop.topic('rb_cmd_vel')
    subscription = interop.ros.subscription(topic, 'geometry_msgs/msg/Twist')
    talker = roslibpy.Topic(web, topic, 'geometry_msgs/Twist')
    expected = zros.Message('geometry_msgs/msg/Twist', linear={'x': 0.5}, angular={'z': 1.0})
    received: list[bytes] = []

    def arrived() -> bool:  # publish until the route through the bridge carries it
        talker.publish(roslibpy.Message({'linear': {'x': 0.5}, 'angular': {'z': 1.0}}))
        received.extend(interop.ros.wait_messages(subscription, 1, timeout=0.2))
        return bool(received)

    assert wait_for(arrived, TIMEOUT)
    assert received[0] == expected.serialize()


def test_roslibpy_calls_an_rclpy_service(interop: Interop, gateway: Any, web: Any) -> None:
    name = interop.topic('rb_echo')
    interop.ros.service(name, 'std_srvs/srv/SetBool')  # echoes the request's fields it shares
    client = roslibpy.Service(web, name, 'std_srvs/SetBool')
    assert wait_for(lambda: name in web.get_services(), TIMEOUT)
    response = client.call(roslibpy.ServiceRequest({'data': True}), timeout=TIMEOUT)
    assert response == {'success': False, 'message': ''}  # SetBool shares no field name


def test_roslibjs_gets_what_rclpy_publishes(interop: Interop, gateway: Any) -> None:
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String

    require_roslib()
    topic = interop.topic('rb_js')
    publisher = interop.ros.publisher(topic, 'std_msgs/msg/String')
    client = RoslibClient(gateway.url)
    try:
        client.command('subscribe', topic=topic, type='std_msgs/msg/String')
        assert interop.ros.wait_subscribers(publisher, timeout=TIMEOUT) >= 1

        def arrived() -> bool:
            interop.ros.publish(publisher, [bytes(serialize_message(String(data='to node')))])
            return bool(client.messages(topic))

        assert wait_for(arrived, TIMEOUT)
        assert client.messages(topic)[0] == {'data': 'to node'}
    finally:
        client.close()
