"""Actions between zros nodes: goals, feedback, status, results, cancel, abort, rejection."""

from __future__ import annotations

import asyncio
import logging
import threading
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from zenoh import ZError

import zros
from tests.support.wire_support import reply_options, request_options, service_key
from zros.actions import (
    ActionError,
    CancelResponse,
    CancelReturn,
    GoalRejectedError,
    GoalResponse,
    GoalStatus,
    ServerGoalHandle,
)
from zros.actions import client as action_client
from zros.actions import server as action_server
from zros.cdr import decode, encode
from zros.node import Node
from zros.services import ServiceUnavailableError
from zros.testing import spinning, wait_for


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module that makes nodes runs on both wire schemes."""
    return str(request.param)


FIB = 'example_interfaces/action/Fibonacci'
#: seconds to wait for what must happen (generous: a loaded 2-core machine stalls for seconds)
DEADLINE = 30.0


def fibonacci(goal: ServerGoalHandle, gate: threading.Event | None = None) -> Any:
    """Counts the sequence, with feedback at each step; waits on ``gate`` when given."""
    sequence = [0, 1]
    for i in range(1, goal.request.order):
        if gate is not None:
            gate.wait(DEADLINE)
        if goal.is_cancel_requested:
            goal.canceled()
            break
        sequence.append(sequence[i] + sequence[i - 1])
        goal.publish_feedback(sequence=sequence)
    return goal.server.Result(sequence=sequence)


@pytest.fixture
def pair(zros_node: Callable[..., Node]) -> tuple[Node, Node]:
    return zros_node('server'), zros_node('client')


@pytest.fixture
def gate() -> Iterator[threading.Event]:
    """Holds a goal's steps until the test opens it."""
    event = threading.Event()
    yield event
    event.set()  # never leave a goal thread waiting


def goal_with_feedback(pair: tuple[Node, Node], order: int) -> tuple[Any, list[list[int]]]:
    """A Fibonacci goal of ``order`` sent from the second node of ``pair`` to the first, and
    the sequences its feedback callbacks received (as the client node spins)."""
    server_node, client_node = pair
    server_node.create_action_server(FIB, 'fibonacci', fibonacci)
    client = client_node.create_action_client(FIB, 'fibonacci')
    assert client.wait_for_server()
    feedback: list[list[int]] = []
    handle = client.send_goal(
        order=order, feedback_callback=lambda f: feedback.append(list(f.sequence))
    )
    return handle, feedback


def test_a_goal_runs_with_feedback_and_status(pair: tuple[Node, Node]) -> None:
    client_node = pair[1]
    handle, feedback = goal_with_feedback(pair, 10)
    assert handle.accepted and handle.stamp is not None
    result = handle.result(timeout=DEADLINE)
    assert list(result.sequence) == [0, 1, 1, 2, 3, 5, 8, 13, 21, 34, 55]
    assert handle.status is GoalStatus.SUCCEEDED and handle.done
    # feedback travels on a topic, the result as a reply: the last feedback may come after it
    assert wait_for(lambda: handle.feedback_count == 9)
    assert list(handle.feedback.sequence) == list(result.sequence)
    assert feedback == []  # callbacks wait for the client node to spin
    assert wait_for(lambda: client_node.spin_once(0.05) == 0 and len(feedback) == 9)
    assert feedback[0] == [0, 1, 1] and feedback[-1] == list(result.sequence)


def test_feedback_waiting_for_a_node_that_does_not_spin_keeps_the_newest(
    pair: tuple[Node, Node],
) -> None:
    # as rclpy's feedback subscription (keep last 10): a client node that never spins holds
    # the newest FEEDBACK_DEPTH callbacks, not one per feedback message ever received
    client_node = pair[1]
    handle, feedback = goal_with_feedback(pair, 40)
    result = list(handle.result(timeout=DEADLINE).sequence)
    assert wait_for(lambda: handle.feedback_count == 39)
    assert wait_for(lambda: client_node.spin_once(0.05) == 0 and len(feedback) >= 10)
    depth = action_client.FEEDBACK_DEPTH
    assert [len(f) for f in feedback] == list(range(len(result) - depth + 1, len(result) + 1))
    assert feedback[-1] == result


def test_feedback_and_status_are_urgent_but_batched(pair: tuple[Node, Node]) -> None:
    # an express message takes a transmission batch of its own and a link queues 2 per
    # priority: under DROP (reliable keep-last), a burst the link's thread had not sent yet lost
    # all but 2 (7 of 9 feedback messages on a loaded machine); batched, the burst shares a batch
    server_node, _ = pair
    server = server_node.create_action_server(FIB, 'fibonacci', fibonacci)
    for publisher in (server._feedback, server._status):
        assert (publisher.priority, publisher.express) == (zros.Priority.INTERACTIVE_HIGH, False)


def test_polling_the_status_of_a_goal(pair: tuple[Node, Node], gate: threading.Event) -> None:
    server_node, client_node = pair
    server = server_node.create_action_server(FIB, 'fib', lambda g: fibonacci(g, gate))
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=3)
    assert handle.wait_for_status(lambda s: s is GoalStatus.EXECUTING, timeout=DEADLINE)
    assert not handle.done and not server.goals[0].done
    with pytest.raises(TimeoutError, match=r'did not end within 0\.05 s'):
        handle.result(timeout=0.05)
    gate.set()
    assert list(handle.result(timeout=DEADLINE).sequence) == [0, 1, 1, 2]
    assert server.goals[0].done  # the server's side: its result is known


def test_two_concurrent_goals(pair: tuple[Node, Node], gate: threading.Event) -> None:
    server_node, client_node = pair
    server = server_node.create_action_server(FIB, 'fib', lambda g: fibonacci(g, gate))
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    short, long = client.send_goal(order=3), client.send_goal(order=6)
    assert short.goal_id != long.goal_id
    assert wait_for(lambda: [g.status for g in server.goals] == [GoalStatus.EXECUTING] * 2)
    gate.set()
    assert list(short.result(DEADLINE).sequence) == [0, 1, 1, 2]
    assert list(long.result(DEADLINE).sequence) == [0, 1, 1, 2, 3, 5, 8]
    assert wait_for(lambda: (short.feedback_count, long.feedback_count) == (2, 5))
    assert list(short.feedback.sequence) == [0, 1, 1, 2]  # no feedback crossed over


def test_cancel_a_running_goal(pair: tuple[Node, Node], gate: threading.Event) -> None:
    server_node, client_node = pair
    server_node.create_action_server(FIB, 'fib', lambda g: fibonacci(g, gate))
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=50)
    assert handle.cancel()
    assert handle.wait_for_status(lambda s: s is GoalStatus.CANCELING, timeout=DEADLINE)
    gate.set()
    assert list(handle.result(DEADLINE).sequence) == [0, 1]
    assert handle.status is GoalStatus.CANCELED
    assert not handle.cancel()  # already over


def test_a_cancel_between_the_accept_and_the_execution_is_kept(
    pair: tuple[Node, Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    # under load a client's cancel can land after the accept's reply but before the goal starts;
    # the goal's thread is held in that window (it publishes the ACCEPTED status there) until then
    server_node, client_node = pair
    server = server_node.create_action_server(FIB, 'fib', fibonacci)
    publish_status = action_server.ActionServer._publish_status
    first = threading.Event()

    def held_after_the_accept(self: action_server.ActionServer) -> None:
        publish_status(self)
        if not first.is_set():  # the accept's status: hold until the cancel has come
            first.set()
            wait_for(lambda: [g.status for g in server.goals] == [GoalStatus.CANCELING], DEADLINE)

    monkeypatch.setattr(action_server.ActionServer, '_publish_status', held_after_the_accept)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=50)
    assert handle.cancel()
    assert list(handle.result(DEADLINE).sequence) == [0, 1]
    assert handle.status is GoalStatus.CANCELED


def test_a_goal_ends_when_its_status_cannot_go_out(
    pair: tuple[Node, Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    # a session that refuses the status array (it is closing) must not stop the goal's steps
    server_node, client_node = pair
    server = server_node.create_action_server(FIB, 'fib', fibonacci)
    refused: list[Any] = []

    def refuse(message: Any) -> None:
        refused.append(message)
        raise ZError('session closed')

    monkeypatch.setattr(server._status, 'write', refuse)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=3)
    assert list(handle.result(DEADLINE).sequence) == [0, 1, 1, 2]
    assert handle.status is GoalStatus.SUCCEEDED
    assert refused and server.goals[0].done


def test_cancel_return_codes(pair: tuple[Node, Node], gate: threading.Event) -> None:
    server_node, client_node = pair
    refuse = threading.Event()
    server_node.create_action_server(
        FIB,
        'fib',
        lambda g: fibonacci(g, gate),
        cancel_callback=lambda g: CancelResponse.REJECT if refuse.is_set() else True,
    )
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    running = client.send_goal(order=5)
    with spinning(server_node):
        refuse.set()
        response = client._cancel_goal(running.goal_id, DEADLINE)
        assert response.return_code == CancelReturn.REJECTED and not response.goals_canceling
        response = client._cancel_goal(bytes(range(16)), DEADLINE)
        assert response.return_code == CancelReturn.UNKNOWN_GOAL_ID
        refuse.clear()
        gate.set()
        running.result(DEADLINE)
        response = client._cancel_goal(running.goal_id, DEADLINE)
        assert response.return_code == CancelReturn.GOAL_TERMINATED
        gate.clear()
        goals = [client.send_goal(order=5) for _ in range(2)]
        canceled = client.cancel_all_goals(timeout=DEADLINE)
        assert sorted(canceled) == sorted(g.goal_id for g in goals)
        gate.set()
        assert all(
            g.result(DEADLINE) is not None and g.status is GoalStatus.CANCELED for g in goals
        )


def test_a_rejected_goal(pair: tuple[Node, Node]) -> None:
    server_node, client_node = pair
    seen: list[int] = []

    def only_small(goal: Any) -> GoalResponse:
        seen.append(goal.order)
        return GoalResponse.ACCEPT if goal.order < 20 else GoalResponse.REJECT

    server_node.create_action_server(FIB, 'fib', fibonacci, goal_callback=only_small)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    with spinning(server_node):
        handle = client.send_goal(order=50)
        assert not handle.accepted
        with pytest.raises(GoalRejectedError, match='rejected goal'):
            handle.result(DEADLINE)
        assert list(client.send_goal(order=2).result(DEADLINE).sequence) == [0, 1, 1]
    assert seen == [50, 2]


def test_aborted_goals(pair: tuple[Node, Node], caplog: pytest.LogCaptureFixture) -> None:
    server_node, client_node = pair

    def explicit(goal: ServerGoalHandle) -> Any:
        goal.abort()
        return goal.server.Result(sequence=[7])

    def raising(goal: ServerGoalHandle) -> Any:
        raise RuntimeError('motor stalled')

    def sloppy(goal: ServerGoalHandle) -> Any:
        return 42

    client_of = {}
    for name, execute in (('explicit', explicit), ('raising', raising), ('sloppy', sloppy)):
        server_node.create_action_server(FIB, name, execute)
        client_of[name] = client_node.create_action_client(FIB, name)
        assert client_of[name].wait_for_server()
    with caplog.at_level(logging.ERROR, logger='zros'):
        handle = client_of['explicit'].send_goal(order=3)
        assert list(handle.result(DEADLINE).sequence) == [7] and handle.status is GoalStatus.ABORTED
        handle = client_of['raising'].send_goal(order=3)
        assert list(handle.result(DEADLINE).sequence) == [] and handle.status is GoalStatus.ABORTED
        handle = client_of['sloppy'].send_goal(order=3)
        assert handle.result(DEADLINE) is not None and handle.status is GoalStatus.ABORTED
    assert 'RuntimeError: motor stalled' in caplog.text
    assert 'returned int, not example_interfaces/action/Fibonacci_Result' in caplog.text


def test_goal_state_rules(pair: tuple[Node, Node]) -> None:
    server_node, client_node = pair
    errors: list[str] = []

    def execute(goal: ServerGoalHandle) -> Any:
        try:
            goal.canceled()  # nobody asked to cancel
        except ActionError as exc:
            errors.append(str(exc))
        goal.succeed()
        try:
            goal.abort()
        except ActionError as exc:
            errors.append(str(exc))
        with pytest.raises(TypeError, match='not both'):
            goal.publish_feedback(goal.server.Feedback(), sequence=[1])
        return None  # an empty result

    server_node.create_action_server(FIB, 'fib', execute)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=1)
    assert list(handle.result(DEADLINE).sequence) == [] and handle.status is GoalStatus.SUCCEEDED
    assert [e.split(': ')[1] for e in errors] == [
        'it cannot become canceled',
        'it cannot become aborted',
    ]


def test_async_execute_callbacks(pair: tuple[Node, Node]) -> None:
    server_node, client_node = pair

    async def execute(goal: ServerGoalHandle) -> Any:
        for step in range(goal.request.order):
            goal.publish_feedback(sequence=[step])
            await asyncio.sleep(0.001)
        return goal.server.Result(sequence=[goal.request.order])

    server_node.create_action_server(FIB, 'fib', execute)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handles = [client.send_goal(order=n) for n in (3, 4, 5)]
    assert [list(h.result(DEADLINE).sequence) for h in handles] == [[3], [4], [5]]
    assert wait_for(lambda: [h.feedback_count for h in handles] == [3, 4, 5])


def test_a_client_that_starts_before_its_server(zros_node: Callable[..., Node]) -> None:
    client_node, server_node = zros_node('client'), zros_node('server')
    client = client_node.create_action_client(FIB, 'late')
    assert not client.server_is_ready()
    assert not client.wait_for_server(timeout=0.2)
    with pytest.raises(ServiceUnavailableError, match='no server for /late/_action/send_goal'):
        client.send_goal(order=1)
    threading.Timer(0.2, lambda: server_node.create_action_server(FIB, 'late', fibonacci)).start()
    assert client.wait_for_server(timeout=DEADLINE)
    assert list(client.send_goal(order=2).result(DEADLINE).sequence) == [0, 1, 1]


def test_results_are_kept_then_forgotten(pair: tuple[Node, Node]) -> None:
    server_node, client_node = pair
    # long enough for the second ask to come before it, on a loaded machine
    server = server_node.create_action_server(FIB, 'fib', fibonacci, result_timeout=5.0)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=4)
    handle.result(DEADLINE)
    late = client._get_result.Request()
    late.goal_id.uuid = handle.goal_id
    response = client._get_result.call(late, DEADLINE)  # as a second client would, after the end
    assert response.status == GoalStatus.SUCCEEDED
    assert list(response.result.sequence) == [0, 1, 1, 2, 3]
    assert wait_for(lambda: not server.goals, timeout=DEADLINE)
    response = client._get_result.call(late, DEADLINE)
    assert response.status == GoalStatus.UNKNOWN


def test_a_server_remembers_a_bounded_number_of_goals(
    pair: tuple[Node, Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(action_server, 'MAX_FINISHED', 3)
    server_node, client_node = pair
    server = server_node.create_action_server(FIB, 'fib', fibonacci)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    for _ in range(6):
        client.send_goal(order=1).result(DEADLINE)
    assert wait_for(lambda: len(server.goals) == 3)


def test_wire_bytes_match_the_bridge_spec(pair: tuple[Node, Node]) -> None:
    """bridge-protocol.md §6: send_goal order=10, get_result status 4 with [0, 1, 1]."""
    server_node, client_node = pair
    action = zros.get_type(FIB)
    captured: list[bytes] = []
    session = server_node.transport.session

    def on_send_goal(query: Any) -> None:
        captured.append(query.payload.to_bytes())
        with query:
            response = encode(action.SendGoal.Response(accepted=False))
            query.reply(query.key_expr, response, **reply_options(query))

    def key(part: str, srv_type: str) -> str:
        return service_key(server_node, f'/fib/_action/{part}', srv_type)

    queryables = [
        session.declare_queryable(key('send_goal', f'{FIB}_SendGoal'), on_send_goal, complete=True),
        session.declare_queryable(key('get_result', f'{FIB}_GetResult'), lambda q: q.drop(),
                                  complete=True),
        session.declare_queryable(key('cancel_goal', 'action_msgs/srv/CancelGoal'),
                                  lambda q: q.drop(), complete=True),
    ]  # fmt: skip
    try:
        client = client_node.create_action_client(FIB, 'fib')
        assert client.wait_for_server()
        handle = client.send_goal(order=10)
        assert not handle.accepted
        (payload,) = captured
        assert payload[:4] == bytes.fromhex('00010000') and len(payload) == 24
        assert payload[4:20] == handle.goal_id and payload[20:] == bytes.fromhex('0a000000')
    finally:
        for queryable in queryables:
            queryable.undeclare()
    response = action.GetResult.Response(status=4, result=action.Result(sequence=[0, 1, 1]))
    assert encode(response) == bytes.fromhex('000100000400000003000000000000000100000001000000')


def test_status_reaches_late_subscribers(pair: tuple[Node, Node]) -> None:
    """The status topic is transient local: a monitor that joins later sees the last array."""
    server_node, client_node = pair
    server_node.create_action_server(FIB, 'fib', fibonacci)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=2)
    handle.result(DEADLINE)
    monitor = client_node.create_subscription(
        'action_msgs/msg/GoalStatusArray', '/fib/_action/status', qos='latched'
    )
    assert wait_for(monitor.has_new_message)
    (status,) = monitor.read_message().status_list
    assert bytes(status.goal_info.goal_id.uuid) == handle.goal_id
    assert status.status == GoalStatus.SUCCEEDED


@pytest.mark.parametrize('zros_wire', ['bridge'])  # rmw_zenoh: tests/rmw/test_runtime.py
def test_only_the_action_tokens_are_announced(pair: tuple[Node, Node]) -> None:
    """Never MP/SS tokens for the _action parts: the bridge would build a second route."""
    server_node, client_node = pair
    server_node.create_action_server(FIB, '/robot/fib', fibonacci)
    client_node.create_action_client(FIB, '/robot/fib')
    graph = client_node.graph

    def kinds() -> set[str]:
        return {e.kind.value for e in graph.endpoints() if e.key.startswith('robot/fib')}

    assert graph.wait_until(lambda: kinds() == {'AS', 'AC'}, timeout=DEADLINE), kinds()
    assert graph.actions() == {'/robot/fib': [FIB]}
    assert not any('_action' in name for name in {**graph.topics(), **graph.services()})


def test_requests_that_do_not_decode(
    pair: tuple[Node, Node], caplog: pytest.LogCaptureFixture
) -> None:
    server_node, client_node = pair
    server_node.create_action_server(FIB, 'fib', fibonacci)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()  # a query sent before the route exists finds no server
    session = client_node.transport.session
    with caplog.at_level(logging.WARNING, logger='zros'):
        replies = list(
            session.get(
                service_key(client_node, '/fib/_action/send_goal', f'{FIB}_SendGoal'),
                payload=b'\x00\x01\x00\x00\x01',
                **request_options(client_node),
            )
        )
    assert replies and replies[0].err is not None
    assert 'does not decode' in replies[0].err.payload.to_string()
    assert 'does not decode' in caplog.text
    assert client.send_goal(order=1).result(DEADLINE) is not None  # the server still works


def test_goal_and_cancel_callbacks_run_on_the_spinning_thread(pair: tuple[Node, Node]) -> None:
    server_node, client_node = pair
    threads: list[threading.Thread] = []
    gate = threading.Event()

    def goal_callback(goal: Any) -> bool:
        threads.append(threading.current_thread())
        return True

    def cancel_callback(goal: ServerGoalHandle) -> bool:
        threads.append(threading.current_thread())
        gate.set()
        return True

    server_node.create_action_server(
        FIB,
        'fib',
        lambda g: fibonacci(g, gate),
        goal_callback=goal_callback,
        cancel_callback=cancel_callback,
    )
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    future = client.send_goal_async(order=5)
    assert wait_for(lambda: server_node.spin_once(0.05) > 0)
    handle = future.result(DEADLINE)
    cancel = threading.Thread(target=handle.cancel)
    cancel.start()
    assert wait_for(lambda: server_node.spin_once(0.05) > 0)
    cancel.join(DEADLINE)
    handle.result(DEADLINE)
    assert threads == [threading.current_thread()] * 2


def test_closing_the_server_ends_what_waits_for_it(
    pair: tuple[Node, Node], gate: threading.Event
) -> None:
    server_node, client_node = pair
    server = server_node.create_action_server(FIB, 'fib', lambda g: fibonacci(g, gate))
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    handle = client.send_goal(order=3)
    assert wait_for(lambda: len(server.goals) == 1)
    server.close()
    # the result request was either held by the server or still on its way
    with pytest.raises(ActionError, match=r'server /fib closed|no server for /fib'):
        handle.result(DEADLINE)
    assert wait_for(lambda: not client.server_is_ready())


def test_mistakes_are_named(pair: tuple[Node, Node]) -> None:
    _, node = pair
    with pytest.raises(TypeError, match='is not an action type'):
        node.create_action_client('example_interfaces/srv/AddTwoInts', 'x')
    client = node.create_action_client(FIB, 'fib')
    with pytest.raises(TypeError, match='takes example_interfaces/action/Fibonacci_Goal goals'):
        client.send_goal(zros.Message('std_msgs/msg/String'))
    with pytest.raises(TypeError, match='not both'):
        client.send_goal(client.Goal(), order=1)
    client.close()
    with pytest.raises(ActionError, match='was closed'):
        client.send_goal(order=1)


def test_rosr_shaped_classes_on_the_default_node(zros_router: Any) -> None:
    zros.init('rosr', connect=zros_router.endpoint, handle_sigint=False)
    try:
        zros.ActionServer('fib', FIB, fibonacci)
        client = zros.ActionClient('fib', FIB)
        assert client.wait_for_server()
        assert list(client.send_goal(order=3).result(DEADLINE).sequence) == [0, 1, 1, 2]
    finally:
        zros.shutdown()


def test_decoded_results_are_plain_messages(pair: tuple[Node, Node]) -> None:
    server_node, client_node = pair
    server_node.create_action_server(FIB, 'fib', fibonacci)
    client = client_node.create_action_client(FIB, 'fib')
    assert client.wait_for_server()
    result = client.send_goal(order=3).result(DEADLINE)
    action = zros.get_type(FIB)
    assert decode(action.Result, encode(result)) == result
