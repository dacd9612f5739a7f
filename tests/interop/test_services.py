"""Services and actions through the bridge, seen from a plain Zenoh session (§5, §6).

These tests drive the Zenoh side by hand, byte by byte as the spec says a client or server
must, and so check the bridge itself (stand-in or real) against real rclpy servers, clients and
actions, independently of zros. zros's own services and actions against rclpy are tested in
``test_zros_services.py``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip(
    'rclpy.serialization',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)

import zenoh
from action_msgs.msg import GoalStatus, GoalStatusArray
from action_msgs.srv import CancelGoal
from rclpy.serialization import deserialize_message, serialize_message
from test_msgs.action import Fibonacci
from test_msgs.srv import BasicTypes
from unique_identifier_msgs.msg import UUID

from tests.interop import rig
from tests.interop.bridge_standin import protocol as p
from tests.interop.conftest import Interop
from zros.testing import wait_for

TIMEOUT = rig.DEADLINE
SRV = 'test_msgs/srv/BasicTypes'
ACTION = 'test_msgs/action/Fibonacci'
HEADER_LE = b'\x00\x01\x00\x00'


@pytest.fixture
def raw_session(interop_bridge: rig.BridgeUnderTest) -> Iterator[Any]:
    config = {
        'mode': 'client',
        'connect': {'endpoints': [interop_bridge.endpoint]},
        'scouting': {'multicast': {'enabled': False}},
        'transport': {'shared_memory': {'enabled': False}},
    }
    session = zenoh.open(zenoh.Config.from_json5(json.dumps(config)))
    yield session
    session.close()


def wait_for_queryable(session: Any, key: str) -> None:
    querier = session.declare_querier(key)
    try:
        assert wait_for(lambda: querier.matching_status.matching, TIMEOUT), f'no queryable on {key}'
    finally:
        querier.undeclare()


def bridge_tokens(session: Any, kind: p.Kind, key: str) -> list[p.Token]:
    found = []
    for reply in session.liveliness().get('@/*/@ros2_lv/**', timeout=5.0):
        if reply.ok is None:
            continue
        token = p.parse_token(str(reply.ok.key_expr))
        if isinstance(token, p.Token) and token.kind is kind and token.key == key:
            found.append(token)
    return found


def ok_replies(session: Any, key: str, payload: bytes, timeout: float = TIMEOUT) -> list[bytes]:
    replies = session.get(key, payload=payload, timeout=timeout)
    return [reply.ok.payload.to_bytes() for reply in replies if reply.ok is not None]


def request(**values: Any) -> Any:
    return BasicTypes.Request(**values)


# --- services -----------------------------------------------------------------------------------


def test_ros_service_server_answers_zenoh_queries(interop: Interop, raw_session: Any) -> None:
    service = interop.topic('echo')
    key = p.ros_to_key(service, interop.bridge.namespace)
    interop.ros.service(service, SRV)
    assert wait_for(lambda: bridge_tokens(raw_session, p.Kind.SS, key), TIMEOUT)
    assert bridge_tokens(raw_session, p.Kind.SS, key)[0].type_name == SRV
    wait_for_queryable(raw_session, key)

    sent = request(int32_value=-7, uint64_value=2**63, string_value='h\u00e9llo', float64_value=1.5)
    replies = ok_replies(raw_session, key, bytes(serialize_message(sent)))
    assert len(replies) == 1, 'the bridge replies exactly once'
    # the Zenoh reply is CDR header + response body, no request id (§5); Fast CDR leaves
    # padding bytes uninitialised, so the length and the decoded value are compared
    expected = bytes(serialize_message(BasicTypes.Response(**_fields(sent))))
    assert replies[0][:4] == HEADER_LE
    assert len(expected) <= len(replies[0]) < len(expected) + 4
    assert deserialize_message(replies[0], BasicTypes.Response) == BasicTypes.Response(
        **_fields(sent)
    )


def _fields(message: Any) -> dict[str, Any]:
    return {name: getattr(message, name) for name in message.get_fields_and_field_types()}


def test_invalid_requests_get_no_reply(interop: Interop, raw_session: Any) -> None:
    """A payload that is not CDR (JSON here, issue zenoh#1363) is dropped by the bridge."""
    service = interop.topic('echo')
    key = p.ros_to_key(service, interop.bridge.namespace)
    interop.ros.service(service, SRV)
    wait_for_queryable(raw_session, key)
    assert ok_replies(raw_session, key, b'{"int32_value": 1}', timeout=3.0) == []
    # and the route still works afterwards
    assert len(ok_replies(raw_session, key, bytes(serialize_message(request())))) == 1


def test_zenoh_service_server_answers_ros_clients(interop: Interop, raw_session: Any) -> None:
    service = interop.topic('zenoh_server')
    key = p.ros_to_key(service, interop.bridge.namespace)
    attachments: list[bytes | None] = []

    def on_query(query: Any) -> None:
        with query:
            attachment = query.attachment
            attachments.append(attachment.to_bytes() if attachment is not None else None)
            received = deserialize_message(query.payload.to_bytes(), BasicTypes.Request)
            answer = BasicTypes.Response(
                int64_value=received.int64_value * 2, string_value=received.string_value.upper()
            )
            query.reply(query.key_expr, bytes(serialize_message(answer)))

    queryable = raw_session.declare_queryable(key, on_query)
    token = raw_session.liveliness().declare_token(
        p.Token(str(raw_session.zid()), p.Kind.SS, key, SRV).to_key()
    )
    try:
        for value in (21, -4):
            sent = request(int64_value=value, string_value='abc')
            data = interop.ros.call_service(service, SRV, bytes(serialize_message(sent)))
            response = deserialize_message(data, BasicTypes.Response)
            assert (response.int64_value, response.string_value) == (2 * value, 'ABC')
        # queries from the bridge carry the 20-byte "rqh" request header
        assert len(attachments) == 2
        headers = [p.parse_request_header(attachment) for attachment in attachments]
        assert all(header is not None and header[2] for header in headers), attachments
    finally:
        token.undeclare()
        queryable.undeclare()


def test_invalid_zenoh_replies_leave_ros_clients_waiting(
    interop: Interop, raw_session: Any
) -> None:
    """The bridge drops a reply that is not CDR: the ROS client never gets a response."""
    service = interop.topic('bad_server')
    key = p.ros_to_key(service, interop.bridge.namespace)

    def on_query(query: Any) -> None:
        with query:
            query.reply(query.key_expr, b'{"int64_value": 1}')

    queryable = raw_session.declare_queryable(key, on_query)
    token = raw_session.liveliness().declare_token(
        p.Token(str(raw_session.zid()), p.Kind.SS, key, SRV).to_key()
    )
    try:
        with pytest.raises(rig.RigError, match='no response'):
            interop.ros.call_service(service, SRV, bytes(serialize_message(request())), 2.0)
    finally:
        token.undeclare()
        queryable.undeclare()


# --- actions ------------------------------------------------------------------------------------


def fibonacci(order: int) -> list[int]:
    sequence = [0, 1]
    for _ in range(1, order):
        sequence.append(sequence[-1] + sequence[-2])
    return sequence


def test_ros_action_server_from_zenoh(interop: Interop, raw_session: Any) -> None:
    action = interop.topic('fibonacci')
    key = p.ros_to_key(action, interop.bridge.namespace)
    interop.ros.action_server(action)
    assert wait_for(lambda: bridge_tokens(raw_session, p.Kind.AS, key), TIMEOUT)
    assert bridge_tokens(raw_session, p.Kind.AS, key)[0].type_name == ACTION
    # no MP/SS tokens for the _action parts (§3.2)
    assert not bridge_tokens(raw_session, p.Kind.SS, p.action_key(key, 'send_goal'))
    assert not bridge_tokens(raw_session, p.Kind.MP, p.action_key(key, 'feedback'))

    feedback: list[bytes] = []
    statuses: list[bytes] = []
    subscribers = [
        raw_session.declare_subscriber(
            p.action_key(key, 'feedback'), lambda s: feedback.append(s.payload.to_bytes())
        ),
        raw_session.declare_subscriber(
            p.action_key(key, 'status'), lambda s: statuses.append(s.payload.to_bytes())
        ),
    ]
    for part in p.ACTION_SERVICES:
        wait_for_queryable(raw_session, p.action_key(key, part))
    if interop.bridge.rig is not None:
        # the stand-in's readers for feedback and status exist once our subscribers match
        prefix = f'@/{interop.bridge.rig.zid}/ros2/route/action/srv/{key}'

        def parts_active() -> bool:
            routes = {
                str(r.ok.key_expr): json.loads(r.ok.payload.to_string())
                for r in raw_session.get(prefix, timeout=5.0)
                if r.ok is not None
            }
            parts = routes.get(prefix, {}).get('parts', {})
            return bool(parts) and parts['feedback']['is_active'] and parts['status']['is_active']

        assert wait_for(parts_active, TIMEOUT)
    # and the server's feedback writer has discovered the bridge's reader: before that, DDS
    # drops what it writes (the goal runs in milliseconds)
    assert interop.ros.wait_readers(f'{action}/_action/feedback') >= 1

    def feedback_of(goal_id: UUID) -> list[list[int]]:
        messages = (deserialize_message(data, Fibonacci.Impl.FeedbackMessage) for data in feedback)
        return [list(m.feedback.sequence) for m in messages if m.goal_id == goal_id]

    def run_goal() -> UUID:
        goal_id = UUID(uuid=list(os.urandom(16)))
        goal = Fibonacci.Impl.SendGoalService.Request(goal_id=goal_id, goal=Fibonacci.Goal(order=5))
        replies = ok_replies(raw_session, p.action_key(key, 'send_goal'), serialize_message(goal))
        assert len(replies) == 1
        assert deserialize_message(replies[0], Fibonacci.Impl.SendGoalService.Response).accepted

        ask = Fibonacci.Impl.GetResultService.Request(goal_id=goal_id)
        replies = ok_replies(raw_session, p.action_key(key, 'get_result'), serialize_message(ask))
        assert len(replies) == 1
        result = deserialize_message(replies[0], Fibonacci.Impl.GetResultService.Response)
        assert result.status == GoalStatus.STATUS_SUCCEEDED
        assert list(result.result.sequence) == fibonacci(5)

        def succeeded() -> bool:
            for data in statuses:
                for status in deserialize_message(data, GoalStatusArray).status_list:
                    if (
                        status.goal_info.goal_id == goal_id
                        and status.status == GoalStatus.STATUS_SUCCEEDED
                    ):
                        return True
            return False

        assert wait_for(succeeded, TIMEOUT)
        return goal_id

    # The server's writer matching the bridge's reader is not the reader matching the writer:
    # on a loaded machine Fast DDS has dropped all of a first goal's (volatile) feedback while
    # the reader's side of discovery lagged (seen once in CI). A later goal must get its feedback.
    goals = [run_goal()]
    while not wait_for(lambda: bool(feedback_of(goals[-1])), 2.0) and len(goals) < 3:
        goals.append(run_goal())
    goal_id = goals[-1]
    sequences = feedback_of(goal_id)
    assert sequences, 'no feedback reached Zenoh (3 goals)'
    for sequence in sequences:
        assert sequence == fibonacci(5)[: len(sequence)]

    cancel = CancelGoal.Request()
    cancel.goal_info.goal_id = goal_id
    replies = ok_replies(raw_session, p.action_key(key, 'cancel_goal'), serialize_message(cancel))
    assert len(replies) == 1
    assert deserialize_message(replies[0], CancelGoal.Response).return_code in (
        CancelGoal.Response.ERROR_GOAL_TERMINATED,
        CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID,
    )
    for subscriber in subscribers:
        subscriber.undeclare()


def test_zenoh_action_server_for_ros_clients(interop: Interop, raw_session: Any) -> None:
    action = interop.topic('zenoh_fibonacci')
    key = p.ros_to_key(action, interop.bridge.namespace)
    goals: dict[bytes, int] = {}
    feedback = raw_session.declare_publisher(p.action_key(key, 'feedback'))

    def send_goal(query: Any) -> None:
        with query:
            goal = deserialize_message(
                query.payload.to_bytes(), Fibonacci.Impl.SendGoalService.Request
            )
            goals[bytes(goal.goal_id.uuid)] = goal.goal.order
            answer = Fibonacci.Impl.SendGoalService.Response(accepted=True)
            query.reply(query.key_expr, bytes(serialize_message(answer)))

    def cancel_goal(query: Any) -> None:
        with query:
            answer = CancelGoal.Response(return_code=CancelGoal.Response.ERROR_REJECTED)
            query.reply(query.key_expr, bytes(serialize_message(answer)))

    def get_result(query: Any) -> None:
        with query:
            ask = deserialize_message(
                query.payload.to_bytes(), Fibonacci.Impl.GetResultService.Request
            )
            sequence = fibonacci(goals[bytes(ask.goal_id.uuid)])
            for end in range(3, len(sequence) + 1):
                message = Fibonacci.Impl.FeedbackMessage(goal_id=ask.goal_id)
                message.feedback.sequence = sequence[:end]
                feedback.put(bytes(serialize_message(message)))
            answer = Fibonacci.Impl.GetResultService.Response(
                status=GoalStatus.STATUS_SUCCEEDED, result=Fibonacci.Result(sequence=sequence)
            )
            query.reply(query.key_expr, bytes(serialize_message(answer)))

    handlers = {'send_goal': send_goal, 'cancel_goal': cancel_goal, 'get_result': get_result}
    queryables = [
        raw_session.declare_queryable(p.action_key(key, part), handler)
        for part, handler in handlers.items()
    ]
    token = raw_session.liveliness().declare_token(
        p.Token(str(raw_session.zid()), p.Kind.AS, key, ACTION).to_key()
    )
    try:
        outcome = interop.ros.action_call(action, 6)
        assert outcome['accepted']
        assert outcome['status'] == GoalStatus.STATUS_SUCCEEDED
        assert outcome['sequence'] == fibonacci(6)
        for sequence in outcome['feedback']:
            assert sequence == fibonacci(6)[: len(sequence)]
    finally:
        token.undeclare()
        for queryable in queryables:
            queryable.undeclare()
        feedback.undeclare()
