"""roslib (roslibjs) from npm, run by node, against ``zros rosbridge``: topics both ways on
both wires, a 1080p image as CBOR and as JSON fragments, png, AddTwoInts called and served, an
action goal with feedback and one canceled, an action served by roslib (``Action.advertise``),
rosapi's topics, nodes and parameters."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import zros
from tests.gateway.rosbridge.roslib_client import RoslibClient
from zros.testing import spinning, wait_for

Make = Callable[..., Any]
TIMEOUT = 30.0
FIB = 'example_interfaces/action/Fibonacci'


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def test_topics_both_ways(rosbridge: Make, roslibjs: Make, zros_node: Make) -> None:
    gateway = rosbridge()
    client: RoslibClient = roslibjs(gateway)
    node = zros_node('robot')
    pub = node.create_publisher('std_msgs/msg/String', '/chatter')
    sub = node.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    client.command('subscribe', topic='/chatter', type='std_msgs/String')
    assert pub.wait_for_subscribers(TIMEOUT)
    pub.write(zros.Message('std_msgs/msg/String', data='to the browser'))
    client.wait(lambda e: e['ev'] == 'message', TIMEOUT)
    assert client.messages('/chatter') == [{'data': 'to the browser'}]

    def delivered() -> bool:
        twist = {'linear': {'x': 0.25}, 'angular': {'z': 1}}
        client.command('publish', topic='/cmd_vel', type='geometry_msgs/Twist', msg=twist)
        return sub.has_new_message()

    assert wait_for(delivered, TIMEOUT)
    twist = sub.read_message()
    assert (twist.linear.x, twist.angular.z) == (0.25, 1.0)


def image(seq: int) -> Any:
    data = np.full(1920 * 1080 * 3, seq % 251, np.uint8)
    return zros.Message(
        'sensor_msgs/msg/Image',
        header={'frame_id': 'camera', 'stamp': {'sec': seq}},
        height=1080,
        width=1920,
        encoding='rgb8',
        step=1920 * 3,
        data=data,
    )


@pytest.mark.parametrize('compression', ['cbor', 'none', 'png'])
def test_a_1080p_image(rosbridge: Make, roslibjs: Make, zros_node: Make, compression: str) -> None:
    # JSON beyond 1 MB goes as fragments (rosbridge's max_message_size): ~8.3 MB in base64
    gateway = rosbridge(max_message_size=1_000_000)
    client: RoslibClient = roslibjs(gateway)
    pub = zros_node('camera').create_publisher('sensor_msgs/msg/Image', '/image')
    client.command(
        'subscribe', topic='/image', type='sensor_msgs/Image', compression=compression, summary=True
    )
    assert pub.wait_for_subscribers(TIMEOUT)
    pub.write(image(7))
    client.wait(lambda e: e['ev'] == 'message', 60.0)
    assert client.messages('/image') == [
        {'width': 1920, 'height': 1080, 'size': 1920 * 1080 * 3, 'first': 7,
         'stamp': {'sec': 7, 'nanosec': 0}}
    ]  # fmt: skip


def test_services_called_and_served(rosbridge: Make, roslibjs: Make, zros_node: Make) -> None:
    gateway = rosbridge()
    client: RoslibClient = roslibjs(gateway)
    node = zros_node('adder')
    service = node.create_service(
        'example_interfaces/srv/AddTwoInts', '/add', lambda r: service.Response(sum=r.a + r.b)
    )
    with spinning(node):
        assert wait_for(lambda: '/add' in client.rosapi('getServices'), TIMEOUT)
        event = client.answer(
            client.command(
                'call', service='/add', type='example_interfaces/AddTwoInts', args={'a': 1, 'b': 2}
            ),
            'response',
        )
        assert event == {'ev': 'response', 'tag': event['tag'], 'values': {'sum': 3}}
    client.command('serve', service='/web_add', type='example_interfaces/srv/AddTwoInts')
    caller = zros_node('caller').create_client('example_interfaces/srv/AddTwoInts', '/web_add')
    assert caller.wait_for_service(TIMEOUT)
    assert caller.call(a=40, b=2, timeout=TIMEOUT).sum == 42
    # the script reports the request on its output, read on a thread of ours: the response
    # can reach the caller before that line is read
    assert wait_for(lambda: client.of('request'), TIMEOUT)
    assert client.of('request')[0]['args'] == {'a': 40, 'b': 2}


def fibonacci(goal: Any, gate: threading.Event) -> Any:
    sequence = [0, 1]
    for i in range(1, goal.request.order):
        if goal.is_cancel_requested:
            goal.canceled()
            break
        sequence.append(sequence[i] + sequence[i - 1])
        goal.publish_feedback(sequence=sequence)
        if i > 2:  # held from the third step until the gate opens or a cancel comes
            wait_for(lambda: gate.is_set() or goal.is_cancel_requested, TIMEOUT)
    return goal.server.Result(sequence=sequence)


def feedback_of(client: RoslibClient, tag: Any) -> list[dict[str, Any]]:
    """The feedback values the client got for the goal ``tag``."""
    return [e['values'] for e in client.of('feedback') if e['tag'] == tag]


def test_an_action_goal_with_feedback(rosbridge: Make, roslibjs: Make, zros_node: Make) -> None:
    gateway = rosbridge()
    client: RoslibClient = roslibjs(gateway)
    node = zros_node('fib')
    gate = threading.Event()
    node.create_action_server(
        FIB, '/fibonacci', lambda g: fibonacci(g, gate), cancel_callback=lambda g: True
    )
    try:
        with spinning(node):
            # feedback written before the gateway's subscriber reached the server is lost, as
            # in ROS: warm up until a goal's feedback shows the way is open
            for _ in range(5):
                warm_up = client.command('goal', action='/fibonacci', type=FIB, goal={'order': 2})
                assert client.answer(warm_up, 'result')['ev'] == 'result'
                if wait_for(lambda: feedback_of(client, warm_up), TIMEOUT / 5):  # noqa: B023
                    break
            gate.set()
            tag = client.command('goal', action='/fibonacci', type=FIB, goal={'order': 6})
            result = client.answer(tag, 'result')
            assert result['values'] == {'sequence': [0, 1, 1, 2, 3, 5, 8]}
            final = [0, 1, 1, 2, 3, 5, 8]  # feedback is a topic: it may come after the result
            assert wait_for(lambda: len(feedback_of(client, tag)) == 5, TIMEOUT)
            feedback = feedback_of(client, tag)
            assert all(final[: len(f['sequence'])] == f['sequence'] for f in feedback)
            gate.clear()
            tag = client.command(
                'goal', action='/fibonacci', type=FIB, goal={'order': 50}, cancel_after=2
            )
            failure = client.answer(tag, 'result')
            gate.set()
            assert failure['ev'] == 'failure' and 'canceled' in failure['error']
    finally:
        gate.set()


def test_roslib_serves_an_action(rosbridge: Make, roslibjs: Make, zros_node: Make) -> None:
    from zros.actions import GoalStatus

    gateway = rosbridge()
    client: RoslibClient = roslibjs(gateway)
    tag = client.command('serve_action', action='/web_fib', type=FIB)
    caller = zros_node('caller').create_action_client(FIB, '/web_fib')
    assert caller.wait_for_server(TIMEOUT)
    handle = caller.send_goal(order=4)
    assert list(handle.result(TIMEOUT).sequence) == [0, 1, 1, 2, 3]
    assert handle.status is GoalStatus.SUCCEEDED
    assert wait_for(lambda: handle.feedback_count == 3, TIMEOUT)  # sendFeedback at each step
    failed = caller.send_goal(order=-1)  # setFailed
    failed.result(TIMEOUT)
    assert failed.status is GoalStatus.ABORTED
    waiting = caller.send_goal(order=0)
    goal = client.wait(lambda e: e['ev'] == 'goal' and e['goal'] == {'order': 0}, TIMEOUT)
    assert waiting.cancel(TIMEOUT)
    assert client.answer(tag, 'cancel')['id'] == goal['id']
    assert list(waiting.result(TIMEOUT).sequence) == [0]  # setCanceled
    assert waiting.status is GoalStatus.CANCELED
    client.command('unserve_action', action='/web_fib')
    assert wait_for(lambda: not caller.server_is_ready(), TIMEOUT)
    assert not [e for e in client.of('status') if e['status']['level'] == 'error']


def test_rosapi_topics_nodes_and_parameters(
    rosbridge: Make, roslibjs: Make, zros_node: Make
) -> None:
    gateway = rosbridge()
    client: RoslibClient = roslibjs(gateway)
    robot = zros_node('robot', start_parameter_services=True)
    robot.declare_parameters({'max_speed': 0.5})
    robot.create_publisher('std_msgs/msg/String', '/chatter')
    assert wait_for(lambda: '/robot' in client.rosapi('getNodes'), TIMEOUT)
    topics = client.rosapi('getTopics')
    assert '/chatter' in topics['topics']
    assert topics['types'][topics['topics'].index('/chatter')] == 'std_msgs/msg/String'
    assert wait_for(lambda: '/robot:max_speed' in client.rosapi('getParams'), TIMEOUT)
    event = client.answer(client.command('param_get', name='/robot:max_speed'), 'param')
    assert event['value'] == 0.5
    done = client.answer(
        client.command('param_set', name='/robot:max_speed', value=1.25), 'param_set_done'
    )
    assert done['ev'] == 'param_set_done' and robot.get_parameter('max_speed') == 1.25
    refused = client.answer(client.command('param_get', name='/robot:nothing'), 'param')
    assert refused['ev'] == 'failure' and 'is not set' in refused['error']
    details = client.rosapi('getMessageDetails', 'geometry_msgs/msg/Pose')
    assert [d['type'] for d in details] == [
        'geometry_msgs/Pose',
        'geometry_msgs/Point',
        'geometry_msgs/Quaternion',
    ]
