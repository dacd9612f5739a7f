"""Topics through ``zros rosbridge`` with roslibpy (a client no one here wrote): messages of
zros publishers reach roslibpy subscribers, and roslibpy publications reach zros subscribers,
on both wires; subscriptions exist on the Zenoh side only while someone subscribes."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest

import zros
from zros.testing import wait_for

Make = Callable[..., Any]
TIMEOUT = 20.0


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def collect(topic: Any) -> tuple[list[dict[str, Any]], threading.Event]:
    received: list[dict[str, Any]] = []
    arrived = threading.Event()

    def on_message(message: dict[str, Any]) -> None:
        received.append(dict(message))
        arrived.set()

    topic.subscribe(on_message)
    return received, arrived


def test_roslibpy_receives_what_a_zros_node_publishes(
    rosbridge: Make, roslibpy_client: Make, zros_node: Make
) -> None:
    import roslibpy

    gateway = rosbridge()
    talker = zros_node('talker')
    publisher = talker.create_publisher('std_msgs/msg/String', '/chatter')
    ros = roslibpy_client(gateway)
    listener = roslibpy.Topic(ros, '/chatter', 'std_msgs/String')
    received, _ = collect(listener)
    assert wait_for(lambda: gateway.watched() == {'/chatter': 1}, TIMEOUT)

    def delivered() -> bool:  # publish until the tap's route carries it
        publisher.write(zros.Message('std_msgs/msg/String', data='hello web'))
        return bool(received)

    assert wait_for(delivered, TIMEOUT)
    assert received[0] == {'data': 'hello web'}
    listener.unsubscribe()
    assert wait_for(lambda: gateway.watched() == {}, TIMEOUT)  # no client: no tap


def test_zros_receives_what_roslibpy_publishes(
    rosbridge: Make, roslibpy_client: Make, zros_node: Make
) -> None:
    import roslibpy

    gateway = rosbridge()
    listener = zros_node('listener')
    subscriber = listener.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    ros = roslibpy_client(gateway)
    talker = roslibpy.Topic(ros, '/cmd_vel', 'geometry_msgs/msg/Twist')
    talker.advertise()
    assert wait_for(lambda: listener.count_publishers('/cmd_vel') == 1, TIMEOUT)

    def delivered() -> bool:
        talker.publish(roslibpy.Message({'linear': {'x': 0.5}, 'angular': {'z': -1}}))
        return subscriber.has_new_message()

    assert wait_for(delivered, TIMEOUT)
    twist = subscriber.read_message()
    assert (twist.linear.x, twist.angular.z, twist.linear.y) == (0.5, -1.0, 0.0)
