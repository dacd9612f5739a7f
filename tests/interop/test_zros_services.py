"""zros services and actions against real ROS 2 (rclpy) through a zenoh-bridge-ros2dds (§5, §6).

rclpy clients call zros servers and zros clients call rclpy servers, both ways for services
(random ``test_msgs/srv/BasicTypes`` requests and responses, drawn by hypothesis as in
``test_topics.py``) and for ``test_msgs/action/Fibonacci`` goals that succeed, are canceled or
abort. The bridge is the stand-in of ``bridge_standin`` unless ``ZROS_INTEROP_BRIDGE`` names a
real one (see ``rig.py``).
"""

from __future__ import annotations

import logging
import time
from typing import Any

import pytest

pytest.importorskip(
    'rclpy.serialization',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)

from hypothesis import given
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message

from tests.cdr.strategies import message_strategy
from tests.interop import rig
from tests.interop.conftest import Interop
from tests.interop.rclpy_support import rclpy_class, to_rclpy
from tests.interop.test_topics import BATCH, REGISTRY, cls, interop_examples, rclpy_bytes
from zros.actions import ActionServer, CancelReturn, GoalStatus, ServerGoalHandle
from zros.cdr import decode
from zros.services import ServiceUnavailableError
from zros.testing import spinning, wait_for

TIMEOUT = rig.DEADLINE
SRV = 'test_msgs/srv/BasicTypes'
REQUEST = SRV + '_Request'
RESPONSE = SRV + '_Response'
ACTION = 'test_msgs/action/Fibonacci'


def assert_fields_equal(expected: Any, received: Any) -> None:
    """``received`` is a message of the type of ``expected`` with equal fields, one by one."""
    assert received.__msgtype__ == expected.__msgtype__
    got = received.to_dict()
    assert list(got) == list(expected.to_dict())
    for name, value in expected.to_dict().items():
        assert got[name] == value, f'{name}: expected {value!r}, received {got[name]!r}'


def batch(data: Any, node: Any, name: str, label: str) -> list[Any]:
    """Random messages of the classes of ``node``'s registry (zros servers and clients take
    only those: a class of another registry is another type to them)."""
    strategy = message_strategy(node.registry, name)
    return data.draw(st.lists(strategy, min_size=BATCH, max_size=BATCH), label=label)


# --- rclpy clients, zros servers ----------------------------------------------------------------


@interop_examples
@given(data=st.data())
def test_ros_client_calls_a_zros_service(data: Any, interop: Interop) -> None:
    node = interop.node()
    requests = batch(data, node, REQUEST, 'requests')
    responses = batch(data, node, RESPONSE, 'responses')
    received: list[Any] = []

    def handler(request: Any) -> Any:
        received.append(request)
        return responses[len(received) - 1]

    service_name = interop.topic('basic_types')
    try:
        service = node.create_service(SRV, service_name, handler)
        with spinning(node):
            for index, request in enumerate(requests):
                reply = interop.ros.call_service(
                    service_name, SRV, rclpy_bytes(REQUEST, request), TIMEOUT
                )
                assert len(received) == index + 1
                assert_fields_equal(request, received[index])
                assert_fields_equal(responses[index], decode(cls(RESPONSE), reply))
                assert deserialize_message(reply, rclpy_class(RESPONSE)) == to_rclpy(
                    REGISTRY, RESPONSE, responses[index]
                )
        assert (service.received, service.failed) == (len(requests), 0)
    finally:
        node.destroy()


def test_a_raising_zros_handler_leaves_the_ros_client_waiting(
    interop: Interop, caplog: pytest.LogCaptureFixture
) -> None:
    """ROS services have no error channel: the zros error reply stops at the bridge, the rclpy
    call times out, and the zros server answers the next call as usual."""
    node = interop.node()
    Request, Response = node.registry.get_class(REQUEST), node.registry.get_class(RESPONSE)

    def handler(request: Any) -> Any:
        if request.int32_value < 0:
            raise ValueError(f'negative: {request.int32_value}')
        return Response(int64_value=2 * request.int32_value, string_value=request.string_value)

    service_name = interop.topic('raising')
    service = node.create_service(SRV, service_name, handler)
    with spinning(node), caplog.at_level(logging.ERROR, logger='zros'):
        poison = rclpy_bytes(REQUEST, Request(int32_value=-3))
        with pytest.raises(rig.RigError, match='no response from'):
            interop.ros.call_service(service_name, SRV, poison, timeout=2.0)
        assert (service.received, service.failed) == (1, 1)
        good = rclpy_bytes(REQUEST, Request(int32_value=21, string_value='next'))
        reply = interop.ros.call_service(service_name, SRV, good, TIMEOUT)
    assert_fields_equal(Response(int64_value=42, string_value='next'), decode(cls(RESPONSE), reply))
    assert (service.received, service.failed) == (2, 1)
    assert 'ValueError: negative: -3' in caplog.text


# --- zros clients, rclpy servers ----------------------------------------------------------------


@interop_examples
@given(data=st.data())
def test_zros_client_calls_a_ros_service(data: Any, interop: Interop) -> None:
    node = interop.node()
    requests = batch(data, node, REQUEST, 'requests')
    service_name = interop.topic('echo')
    server = interop.ros.service(service_name, SRV)
    try:
        client = node.create_client(SRV, service_name)
        assert client.wait_for_service(TIMEOUT)
        for request in requests:
            # the worker's server copies each request field into the response field of that name
            expected = client.Response(**request.to_dict())
            assert_fields_equal(expected, client.call(request, timeout=TIMEOUT))
    finally:
        node.destroy()
        interop.ros.destroy(server)


def test_zros_client_sees_ros_servers_come_and_go(interop: Interop) -> None:
    service_name = interop.topic('late_echo')
    node = interop.node()
    client = node.create_client(SRV, service_name)
    assert not client.service_is_ready()
    with pytest.raises(ServiceUnavailableError, match='no server'):
        client.call(int32_value=1, timeout=TIMEOUT)

    server = interop.ros.service(service_name, SRV)
    assert client.wait_for_service(TIMEOUT)
    response = client.call(int32_value=5, string_value='up', timeout=TIMEOUT)
    assert (response.int32_value, response.string_value) == (5, 'up')

    interop.ros.destroy(server)
    assert wait_for(lambda: not client.service_is_ready(), TIMEOUT)
    with pytest.raises(ServiceUnavailableError):
        client.call(int32_value=1, timeout=TIMEOUT)


def test_a_service_nobody_serves_is_unavailable(interop: Interop) -> None:
    node = interop.node()
    client = node.create_client(SRV, interop.topic('nobody'))
    assert not client.wait_for_service(timeout=0.5)
    started = time.monotonic()
    with pytest.raises(ServiceUnavailableError, match='no server'):
        client.call(int32_value=1, timeout=TIMEOUT)
    assert time.monotonic() - started < TIMEOUT / 2, 'the call waited for its timeout'


# --- rclpy action clients, zros action servers --------------------------------------------------


def fibonacci(order: int) -> list[int]:
    sequence = [0, 1]
    for _ in range(1, order):
        sequence.append(sequence[-1] + sequence[-2])
    return sequence


def feedback_reaches_the_bridge(server: ActionServer) -> bool:
    """Wait until the bridge subscribes to the server's feedback (returns whether it did).

    The bridge subscribes only once a ROS client's feedback reader matched its DDS writer (the
    stand-in notices at its next graph poll), while rclpy's ``wait_for_server`` returns as soon
    as the writer exists: feedback sent right after the goal arrives could be lost.
    """
    session = server.node.transport.session
    probe = session.declare_publisher(f'{server.key}/_action/feedback')
    try:
        return wait_for(lambda: probe.matching_status.matching, TIMEOUT)
    finally:
        probe.undeclare()


def assert_states(statuses: list[int], end: GoalStatus) -> None:
    """The goal's states seen on the ROS status topic only move forward and end with ``end``."""
    assert statuses, 'the ROS client saw no status of its goal'
    assert statuses == sorted(statuses), statuses
    assert statuses[-1] == end, statuses
    assert set(statuses) <= {GoalStatus.ACCEPTED, GoalStatus.EXECUTING, GoalStatus.CANCELING, end}


def test_ros_client_drives_a_zros_goal_to_success(interop: Interop) -> None:
    ready: list[bool] = []

    def execute(goal: ServerGoalHandle) -> Any:
        ready.append(feedback_reaches_the_bridge(goal.server))
        sequence = [0, 1]
        for _ in range(1, goal.request.order):
            sequence.append(sequence[-1] + sequence[-2])
            goal.publish_feedback(sequence=sequence)
        goal.succeed()
        return goal.server.action_type.Result(sequence=sequence)

    action = interop.topic('fibonacci')
    server = interop.node().create_action_server(ACTION, action, execute)
    outcome = interop.ros.action_call(action, 10, TIMEOUT, record=True, feedback_count=9)
    assert ready == [True]
    assert outcome['accepted']
    assert outcome['status'] == GoalStatus.SUCCEEDED
    assert outcome['sequence'] == fibonacci(10)
    # all feedback crossed the bridge, in order
    expected = [fibonacci(10)[:end] for end in range(3, 12)]
    assert outcome['topic_feedback'] == expected
    # rclpy's ActionClient drops what it takes after the result: its callbacks got a prefix
    assert outcome['feedback'] and outcome['feedback'] == expected[: len(outcome['feedback'])]
    assert_states(outcome['statuses'], GoalStatus.SUCCEEDED)
    goals = server.goals
    assert [(goal.goal_id.hex(), goal.status) for goal in goals] == [
        (outcome['goal_id'], GoalStatus.SUCCEEDED)
    ]
    assert goals[0].request.order == 10


def test_ros_client_cancels_a_zros_goal(interop: Interop) -> None:
    cancel_seen: list[bool] = []

    def execute(goal: ServerGoalHandle) -> Any:
        assert feedback_reaches_the_bridge(goal.server)
        sequence = [0, 1, 1]
        goal.publish_feedback(sequence=sequence)
        # the rclpy client cancels once this feedback reached it
        cancel_seen.append(wait_for(lambda: goal.is_cancel_requested, TIMEOUT))
        if goal.is_cancel_requested:
            goal.canceled()
        return goal.server.action_type.Result(sequence=sequence)

    action = interop.topic('fibonacci')
    server = interop.node().create_action_server(ACTION, action, execute)
    outcome = interop.ros.action_call(action, 10, TIMEOUT, cancel_after_feedback=True, record=True)
    assert cancel_seen == [True]
    assert outcome['cancel'] == {
        'return_code': CancelReturn.NONE,
        'goals_canceling': [outcome['goal_id']],
    }
    assert outcome['status'] == GoalStatus.CANCELED
    assert outcome['sequence'] == [0, 1, 1]
    assert outcome['feedback'] == outcome['topic_feedback'] == [[0, 1, 1]]
    assert_states(outcome['statuses'], GoalStatus.CANCELED)
    assert [goal.status for goal in server.goals] == [GoalStatus.CANCELED]


def test_ros_client_sees_a_zros_goal_abort(interop: Interop) -> None:
    def execute(goal: ServerGoalHandle) -> Any:
        assert feedback_reaches_the_bridge(goal.server)
        goal.publish_feedback(sequence=[0, 1, 1])
        goal.abort()
        return goal.server.action_type.Result(sequence=[0, 1, 1])

    action = interop.topic('fibonacci')
    server = interop.node().create_action_server(ACTION, action, execute)
    outcome = interop.ros.action_call(action, 10, TIMEOUT, record=True, feedback_count=1)
    assert outcome['status'] == GoalStatus.ABORTED
    assert outcome['sequence'] == [0, 1, 1]
    assert outcome['topic_feedback'] == [[0, 1, 1]]
    assert_states(outcome['statuses'], GoalStatus.ABORTED)
    assert [goal.status for goal in server.goals] == [GoalStatus.ABORTED]


# --- zros action clients, rclpy action servers --------------------------------------------------


def ros_action_client(interop: Interop, action: str) -> tuple[Any, Any]:
    """A zros node and its action client of ``action``, ready to send goals."""
    node = interop.node()
    client = node.create_action_client(ACTION, action)
    assert client.wait_for_server(TIMEOUT)
    # the bridge reads a ROS server's feedback only while a Zenoh subscriber (the client's)
    # matches, and wait_for_server() does not wait for that DDS reader: without this the first
    # feedback of a goal may go nowhere
    assert interop.ros.wait_readers(f'{action}/_action/feedback') >= 1
    return node, client


def test_zros_client_drives_a_ros_goal_to_success(interop: Interop) -> None:
    action = interop.topic('ros_fibonacci')
    interop.ros.action_server(action)
    node, client = ros_action_client(interop, action)
    feedback: list[list[int]] = []
    with spinning(node):
        handle = client.send_goal(
            order=8,
            feedback_callback=lambda f: feedback.append(list(f.sequence)),
            timeout=TIMEOUT,
        )
        assert handle.accepted and handle.stamp is not None
        result = handle.result(TIMEOUT)
        assert list(result.sequence) == fibonacci(8)
        assert handle.status is GoalStatus.SUCCEEDED
        # feedback travels on a topic, the result as a reply: the last feedback may come later
        assert wait_for(lambda: len(feedback) == handle.feedback_count == 7, TIMEOUT), feedback
    assert feedback == [fibonacci(8)[:end] for end in range(3, 10)]
    assert list(handle.feedback.sequence) == fibonacci(8)


def test_zros_client_cancels_a_ros_goal(interop: Interop) -> None:
    action = interop.topic('ros_fibonacci')
    # a goal waits after its first step until canceled (at most 2 * TIMEOUT)
    interop.ros.action_server(action, cancelable=True, hold=2 * TIMEOUT)
    _, client = ros_action_client(interop, action)
    handle = client.send_goal(order=10, timeout=TIMEOUT)
    assert handle.accepted
    assert handle.wait_for_status(lambda status: status is GoalStatus.EXECUTING, TIMEOUT)
    assert wait_for(lambda: handle.feedback_count == 1, TIMEOUT)
    assert handle.cancel(TIMEOUT)
    assert list(handle.result(TIMEOUT).sequence) == [0, 1, 1]
    assert handle.status is GoalStatus.CANCELED
    assert handle.feedback_count == 1
    assert not handle.cancel(TIMEOUT)  # already over


def test_zros_client_sees_a_ros_goal_abort(interop: Interop) -> None:
    action = interop.topic('ros_fibonacci')
    interop.ros.action_server(action, abort_order=5)
    _, client = ros_action_client(interop, action)
    handle = client.send_goal(order=5, timeout=TIMEOUT)
    assert handle.accepted
    assert list(handle.result(TIMEOUT).sequence) == [0, 1, 1]
    assert handle.status is GoalStatus.ABORTED
    assert wait_for(lambda: handle.feedback_count == 1, TIMEOUT)
    assert list(handle.feedback.sequence) == [0, 1, 1]
    # the same server succeeds other orders: the abort came from its choice, not a failure
    other = client.send_goal(order=3, timeout=TIMEOUT)
    assert list(other.result(TIMEOUT).sequence) == fibonacci(3)
    assert other.status is GoalStatus.SUCCEEDED
