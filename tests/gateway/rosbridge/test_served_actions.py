"""A web client serving an action through ``zros rosbridge`` (rosbridge_suite's ROS 2 ops:
``advertise_action``, ``action_feedback``, ``action_result``, ``unadvertise_action``), spoken
by hand over a plain WebSocket, with a zros ActionClient on the graph sending the goals, on
both wires: feedback and results, cancel, failure, the client leaving, withdrawal, and each
kind of bad input refused with a status."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from tests.gateway.rosbridge.clients import RawClient
from zros.actions import GoalStatus
from zros.testing import wait_for

Make = Callable[..., Any]
TIMEOUT = 20.0
FIB = 'example_interfaces/action/Fibonacci'


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def advertised(rosbridge: Make, raw_client: Make, zros_node: Make, name: str = '/web_fib') -> Any:
    """A gateway, a raw client serving ``name``, and a zros action client ready to use it."""
    gateway = rosbridge()
    client: RawClient = raw_client(gateway)
    client.send(op='advertise_action', action=name, type=FIB)
    caller = zros_node('caller').create_action_client(FIB, name)
    assert caller.wait_for_server(TIMEOUT)
    return gateway, client, caller


def goal_of(client: RawClient, start: int = 0) -> dict[str, Any]:
    """The next ``send_action_goal`` the gateway forwarded to the client."""
    return client.wait(lambda m: m.get('op') == 'send_action_goal', start=start)


def finish(client: RawClient, goal: dict[str, Any], sequence: list[int], status: int = 4) -> None:
    """Answer ``goal`` with an ``action_result`` (``result: true``)."""
    client.send(
        op='action_result',
        id=goal['id'],
        action=goal['action'],
        values={'sequence': sequence},
        status=status,
        result=True,
    )


def test_a_web_client_serves_goals_with_feedback(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    _, client, caller = advertised(rosbridge, raw_client, zros_node)
    handle = caller.send_goal(order=3)
    assert handle.accepted
    goal = goal_of(client)
    assert goal['action'] == '/web_fib' and goal['action_type'] == FIB
    assert goal['args'] == {'order': 3} and goal['feedback'] is True
    for sequence in ([0, 1, 1], [0, 1, 1, 2]):
        client.send(
            op='action_feedback', id=goal['id'], action='/web_fib', values={'sequence': sequence}
        )
    finish(client, goal, [0, 1, 1, 2])
    assert list(handle.result(TIMEOUT).sequence) == [0, 1, 1, 2]
    assert handle.status is GoalStatus.SUCCEEDED
    # feedback (a topic) and the result (a query reply) travel apart: both feedbacks arrive
    assert wait_for(lambda: handle.feedback_count == 2, TIMEOUT)
    assert list(handle.feedback.sequence) == [0, 1, 1, 2]
    assert not client.of('status')  # nothing was refused


def test_a_cancel_reaches_the_web_client(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    _, client, caller = advertised(rosbridge, raw_client, zros_node)
    handle = caller.send_goal(order=10)
    goal = goal_of(client)
    assert handle.cancel(TIMEOUT)
    cancel = client.wait(lambda m: m.get('op') == 'cancel_action_goal')
    assert cancel == {'op': 'cancel_action_goal', 'id': goal['id'], 'action': '/web_fib'}
    finish(client, goal, [0], 5)
    assert list(handle.result(TIMEOUT).sequence) == [0]
    assert handle.status is GoalStatus.CANCELED


def test_a_failed_goal_is_aborted(rosbridge: Make, raw_client: Make, zros_node: Make) -> None:
    _, client, caller = advertised(rosbridge, raw_client, zros_node)
    handle = caller.send_goal(order=2)
    goal = goal_of(client)
    # roslib's setFailed: no values, result false
    client.send(op='action_result', id=goal['id'], action='/web_fib', status=6, result=False)
    assert list(handle.result(TIMEOUT).sequence) == []
    assert handle.status is GoalStatus.ABORTED
    start = client.mark()
    second = caller.send_goal(order=2)  # an aborted status with values: they are the result
    goal = goal_of(client, start)
    finish(client, goal, [7], 6)
    assert list(second.result(TIMEOUT).sequence) == [7]
    assert second.status is GoalStatus.ABORTED


def test_a_client_leaving_aborts_its_goals_and_withdraws_its_actions(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway, client, caller = advertised(rosbridge, raw_client, zros_node)
    handle = caller.send_goal(order=5)
    goal_of(client)
    client.close()
    # the status says so; the result call may reach the server after it withdrew (under load)
    assert handle.wait_for_status(lambda s: s is GoalStatus.ABORTED, timeout=TIMEOUT)
    assert wait_for(lambda: not caller.server_is_ready(), TIMEOUT)
    # the name is free again: another client serves it
    other: RawClient = raw_client(gateway)
    other.send(op='advertise_action', action='/web_fib', type=FIB)
    assert caller.wait_for_server(TIMEOUT)
    again = caller.send_goal(order=1)
    goal = goal_of(other)
    finish(other, goal, [0, 1])
    assert list(again.result(TIMEOUT).sequence) == [0, 1]


def test_unadvertise_action_aborts_running_goals(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    _, client, caller = advertised(rosbridge, raw_client, zros_node)
    handle = caller.send_goal(order=5)
    goal = goal_of(client)
    client.send(op='unadvertise_action', action='/web_fib')
    assert handle.wait_for_status(lambda s: s is GoalStatus.ABORTED, timeout=TIMEOUT)
    assert wait_for(lambda: not caller.server_is_ready(), TIMEOUT)
    start = client.mark()
    client.send(
        op='action_result', id=goal['id'], action='/web_fib', values={}, status=4, result=True
    )
    assert 'has not been advertised' in client.status('action_result', start)['msg']
    client.send(op='unadvertise_action', action='/web_fib')
    assert "can't unadvertise" in client.status('unadvertise_action', start)['msg']


def refusal(client: RawClient, start: int, **op: Any) -> str:
    """Send ``op`` and return the text of the error status it gets."""
    client.send(**op)
    return str(client.status(str(op['op']), start)['msg'])


def test_bad_input_gets_a_status_and_breaks_nothing(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway, client, caller = advertised(rosbridge, raw_client, zros_node)
    other: RawClient = raw_client(gateway)
    start = client.mark()
    assert 'unknown action type' in refusal(
        client, start, op='advertise_action', action='/other', type='example_interfaces/action/Nope'
    )
    assert 'Expected a type field' in refusal(
        client, client.mark(), op='advertise_action', action='/x'
    )
    assert 'already advertised by another client' in refusal(
        other, other.mark(), op='advertise_action', action='/web_fib', type=FIB
    )
    assert "can't unadvertise" in refusal(
        other, other.mark(), op='unadvertise_action', action='/web_fib'
    )
    handle = caller.send_goal(order=4)
    goal = goal_of(client)
    gid = goal['id']
    fields = {'action': '/web_fib', 'id': gid}
    assert 'unrecognized id' in refusal(
        client, client.mark(), op='action_feedback', action='/web_fib', id='nope', values={}
    )
    assert 'has not been advertised' in refusal(
        client, client.mark(), op='action_feedback', action='/elsewhere', id=gid, values={}
    )
    assert 'has not been advertised' in refusal(  # another client's goal
        other, other.mark(), op='action_feedback', values={'sequence': [1]}, **fields
    )
    assert 'sequence' in refusal(  # the wrong shape: dropped, the goal runs on
        client, client.mark(), op='action_feedback', values={'sequence': 'abc'}, **fields
    )
    assert 'Expected a id field' in refusal(
        client, client.mark(), op='action_result', action='/web_fib', result=True
    )
    client.send(op='action_feedback', values={'sequence': [0, 1]}, **fields)
    assert wait_for(lambda: handle.feedback_count == 1, TIMEOUT)
    assert handle.status is GoalStatus.EXECUTING
    # canceled without a cancel request: the goal ends aborted, and the client is told
    assert 'not asked to cancel' in refusal(
        client,
        client.mark(),
        op='action_result',
        values={'sequence': [1]},
        status=5,
        result=True,
        **fields,
    )
    assert list(handle.result(TIMEOUT).sequence) == [1]
    assert handle.status is GoalStatus.ABORTED
    assert 'unrecognized id' in refusal(  # a result for a goal that ended
        client, client.mark(), op='action_result', values={}, status=4, result=True, **fields
    )
    for bad, status, says in (({'sequence': {}}, 4, 'sequence'), ({}, 9, 'none of 4, 5, 6')):
        start = client.mark()
        handle = caller.send_goal(order=1)
        gid = goal_of(client, start)['id']
        assert says in refusal(
            client, client.mark(), op='action_result', action='/web_fib', id=gid,
            values=bad, status=status, result=True,
        )  # fmt: skip
        handle.result(TIMEOUT)
        assert handle.status is GoalStatus.ABORTED


def test_an_action_outside_the_services_glob_is_refused(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge(services_glob=['/allowed*'])
    client: RawClient = raw_client(gateway)
    assert 'not allowed' in refusal(client, 0, op='advertise_action', action='/secret', type=FIB)
    client.send(op='advertise_action', action='/allowed_fib', type=FIB)
    caller = zros_node('caller').create_action_client(FIB, '/allowed_fib')
    assert caller.wait_for_server(TIMEOUT)


def test_goals_beyond_the_bound_are_aborted_without_reaching_the_client(
    rosbridge: Make, raw_client: Make, zros_node: Make, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.gateway.rosbridge import served_actions as rosbridge_actions

    monkeypatch.setattr(rosbridge_actions, 'MAX_GOALS', 1)
    _, client, caller = advertised(rosbridge, raw_client, zros_node)
    first = caller.send_goal(order=1)
    goal = goal_of(client)
    second = caller.send_goal(order=2)
    second.result(TIMEOUT)
    assert second.status is GoalStatus.ABORTED
    assert len(client.of('send_action_goal')) == 1
    finish(client, goal, [])
    first.result(TIMEOUT)
    assert first.status is GoalStatus.SUCCEEDED


def test_a_server_that_cannot_be_made_frees_the_name(
    rosbridge: Make, raw_client: Make, zros_node: Make, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.errors import ZrosError

    gateway = rosbridge()
    client: RawClient = raw_client(gateway)
    make = gateway.node.create_action_server

    def broken(*args: Any, **kwargs: Any) -> Any:
        raise ZrosError('no room')

    monkeypatch.setattr(gateway.node, 'create_action_server', broken)
    assert 'cannot serve action /web_fib: no room' in refusal(
        client, 0, op='advertise_action', action='/web_fib', type=FIB
    )
    monkeypatch.setattr(gateway.node, 'create_action_server', make)
    client.send(op='advertise_action', action='/web_fib', type=FIB)  # not held by the failure
    assert zros_node('caller').create_action_client(FIB, '/web_fib').wait_for_server(TIMEOUT)
