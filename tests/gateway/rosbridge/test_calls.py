"""Services, client-served services, actions and rosapi through ``zros rosbridge``, with
roslibpy (a client no one here wrote) on both wires: AddTwoInts called and served, a
Fibonacci goal with feedback (and one canceled), rosapi's topics, nodes, parameters and types."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tests.actions.test_actions import fibonacci
from tests.gateway.rosbridge.clients import RawClient
from zros.services import ServiceCallError
from zros.testing import spinning, wait_for

Make = Callable[..., Any]
TIMEOUT = 20.0
ADD = 'example_interfaces/srv/AddTwoInts'
FIB = 'example_interfaces/action/Fibonacci'


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture
def gate() -> Iterator[threading.Event]:
    event = threading.Event()
    yield event
    event.set()


def test_roslibpy_calls_a_zros_service(
    rosbridge: Make, roslibpy_client: Make, zros_node: Make
) -> None:
    import roslibpy

    gateway = rosbridge()
    server = zros_node('adder')
    service = server.create_service(ADD, '/add_two_ints', lambda r: service.Response(sum=r.a + r.b))
    ros = roslibpy_client(gateway)
    client = roslibpy.Service(ros, '/add_two_ints', 'example_interfaces/AddTwoInts')
    with spinning(server):
        assert wait_for(lambda: '/add_two_ints' in ros.get_services(), TIMEOUT)
        assert client.call(roslibpy.ServiceRequest({'a': 2, 'b': 40}), timeout=TIMEOUT) == {
            'sum': 42
        }
        big = client.call(roslibpy.ServiceRequest({'a': 2**62, 'b': 2**62 - 1}), timeout=TIMEOUT)
        assert big == {'sum': 2**63 - 1}  # int64 exact
        with pytest.raises(roslibpy.core.ServiceException):  # a refused request: result false
            client.call(roslibpy.ServiceRequest({'a': 'two'}), timeout=TIMEOUT)


def test_roslibpy_serves_a_service_zros_calls(
    rosbridge: Make, roslibpy_client: Make, zros_node: Make
) -> None:
    import roslibpy

    gateway = rosbridge()
    ros = roslibpy_client(gateway)
    served = roslibpy.Service(ros, '/web_add', 'example_interfaces/AddTwoInts')

    def add(request: dict[str, Any], response: dict[str, Any]) -> bool:
        if request['a'] < 0:
            return False  # roslibpy answers result: false
        response['sum'] = request['a'] + request['b']
        return True

    served.advertise(add)
    caller = zros_node('caller').create_client(ADD, '/web_add', timeout=TIMEOUT)
    assert caller.wait_for_service(TIMEOUT)
    assert caller.call(a=20, b=22).sum == 42
    with pytest.raises(ServiceCallError, match='failed'):
        caller.call(a=-1, b=0)
    served.unadvertise()
    assert wait_for(lambda: not caller.service_is_ready(), TIMEOUT)


def test_roslibpy_sends_an_action_goal_with_feedback(
    rosbridge: Make, roslibpy_client: Make, zros_node: Make
) -> None:
    import roslibpy

    gateway = rosbridge()
    server = zros_node('fib_server')
    server.create_action_server(FIB, '/fibonacci', fibonacci)
    ros = roslibpy_client(gateway)
    feedback: list[dict[str, Any]] = []
    results: list[dict[str, Any]] = []
    done = threading.Event()
    client = roslibpy.ActionClient(ros, '/fibonacci', 'example_interfaces/action/Fibonacci')
    with spinning(server):

        def on_result(result: dict[str, Any]) -> None:
            results.append(dict(result))
            done.set()

        # a first goal makes the gateway's action client: its feedback route is up after it
        warm_up = client.send_goal(roslibpy.Goal({'order': 1}), on_result, print, on_result)
        client.wait_goal(warm_up, TIMEOUT)
        results.clear()
        goal = client.send_goal(
            roslibpy.Goal({'order': 5}), on_result, lambda f: feedback.append(dict(f)), on_result
        )
        client.wait_goal(goal, TIMEOUT)
    assert results[0]['values'] == {'sequence': [0, 1, 1, 2, 3, 5]}
    assert results[0]['status'] == roslibpy.core.GoalStatus.SUCCEEDED
    # feedback and result travel apart (a topic and a query reply): the last feedback may come
    # after the result, and then roslibpy drops it; what came are the growing sequences
    final = [0, 1, 1, 2, 3, 5]
    assert feedback and all(final[: len(f['sequence'])] == f['sequence'] for f in feedback)


def test_a_goal_is_canceled(
    rosbridge: Make, raw_client: Make, zros_node: Make, gate: threading.Event
) -> None:
    gateway = rosbridge()
    server = zros_node('fib_server')
    action = server.create_action_server(
        FIB, '/slow_fib', lambda g: fibonacci(g, gate), cancel_callback=lambda g: True
    )
    client: RawClient = raw_client(gateway)
    with spinning(server):
        client.send(
            op='send_action_goal',
            id='g1',
            action='/slow_fib',
            action_type=FIB,
            args={'order': 50},
            feedback=True,
        )
        assert wait_for(lambda: bool(action.goals), TIMEOUT)
        client.send(op='cancel_action_goal', id='g1', action='/slow_fib')
        assert wait_for(lambda: action.goals[0].is_cancel_requested, TIMEOUT)
        gate.set()
        result = client.wait(lambda m: m.get('op') == 'action_result')
    assert result['id'] == 'g1' and result['status'] == 5 and result['result'] is True  # CANCELED


def test_the_first_topic_list_of_a_new_gateway_is_whole(
    rosbridge: Make, roslibpy_client: Make, zros_node: Make
) -> None:
    """A dashboard asks for the topics once, as it connects: the robot's are all there."""
    robot = zros_node('robot')
    robot.create_publisher('std_msgs/msg/String', '/chatter')
    robot.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    assert wait_for(lambda: '/cmd_vel' in dict(robot.get_topic_names_and_types()), TIMEOUT)
    ros = roslibpy_client(rosbridge())
    assert {'/chatter', '/cmd_vel'} <= set(ros.get_topics())


def test_rosapi(rosbridge: Make, roslibpy_client: Make, zros_node: Make) -> None:

    gateway = rosbridge()
    robot = zros_node('robot', start_parameter_services=True)
    robot.declare_parameters({'speed': 1.5, 'name': 'r2'})
    robot.create_publisher('std_msgs/msg/String', '/chatter')
    robot.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    ros = roslibpy_client(gateway)
    with spinning(robot):
        assert wait_for(lambda: '/robot' in ros.get_nodes(), TIMEOUT)
        topics = ros.get_topics()
        assert {'/chatter', '/cmd_vel'} <= set(topics)
        assert ros.get_topic_type('/chatter') == 'std_msgs/msg/String'
        assert '/chatter' in ros.get_topics_for_type('std_msgs/String')
        details = ros.get_node_details('/robot')
        assert '/chatter' in details['publishing'] and details['subscribing'] == ['/cmd_vel']
        assert '/robot/get_parameters' in details['services']
        assert '/robot/get_parameters' in ros.get_services()
        assert ros.get_service_type('/robot/get_parameters') == 'rcl_interfaces/srv/GetParameters'
        assert wait_for(lambda: '/robot:speed' in ros.get_params(), TIMEOUT)
        assert ros.get_param('/robot:speed') == 1.5
        ros.set_param('/robot:speed', 2.5)
        assert robot.get_parameter('speed') == 2.5
        assert ros.get_param('/robot:name') == 'r2'
        ros.delete_param('/robot:name')  # a declared parameter: the node refuses
        assert robot.get_parameter('name') == 'r2'
        ros.set_param('/robot:speed', 'fast')  # the wrong type: refused, with the reason
        assert robot.get_parameter('speed') == 2.5
        typedefs = ros.get_message_details('geometry_msgs/Twist')['typedefs']
        assert typedefs[0] == {
            'type': 'geometry_msgs/Twist',
            'fieldnames': ['linear', 'angular'],
            'fieldtypes': ['geometry_msgs/Vector3', 'geometry_msgs/Vector3'],
            'fieldarraylen': [-1, -1],
            'examples': ['{}', '{}'],
            'constnames': [],
            'constvalues': [],
        }
        assert typedefs[1]['fieldtypes'] == ['double', 'double', 'double']
        request = ros.get_service_request_details('example_interfaces/AddTwoInts')
        assert request['typedefs'][0]['fieldnames'] == ['a', 'b']
        assert request['typedefs'][0]['fieldtypes'] == ['int64', 'int64']
