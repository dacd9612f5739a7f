"""zros nodes on the rmw_zenoh wire: tokens, ids, GIDs, attachments, services and the graph,
checked on the bytes a raw Zenoh session sees (shared/specs/rmw-zenoh-protocol.md)."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

import pytest
import zenoh

import zros
from zros.cdr import TypeRegistry
from zros.graph import graph_of
from zros.keyexpr.attachment import Attachment
from zros.keyexpr.rmw_zenoh import gid
from zros.node import Node
from zros.qos import LATCHED
from zros.services import ServiceCallError, ServiceUnavailableError
from zros.testing import spinning, wait_for
from zros.transport import Transport

String = 'std_msgs/msg/String'
ADD = 'example_interfaces/srv/AddTwoInts'
FIB = 'example_interfaces/action/Fibonacci'
H = 'RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18'
A = 'RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a'
OTHER_GID = bytes(range(16))


@pytest.fixture
def zros_wire() -> str:
    return 'rmw_zenoh'


def rmw_tokens(transport: Transport) -> list[str]:
    replies = transport.session.liveliness().get('@ros2_lv/0/**')
    return sorted(str(r.ok.key_expr) for r in replies if r.ok is not None)


def add(request: Any) -> Any:
    return zros.get_type(ADD).Response(sum=request.a + request.b)


def test_tokens_ids_and_gids(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    node = zros_node('talker', '/robot', start_parameter_services=False)
    observer = zros_transport()
    zid = node.transport.zid
    pub = node.create_publisher(String, 'chatter', qos='sensor_data')
    second = node.create_publisher(String, 'chatter', qos='sensor_data')
    sub = node.create_subscription('geometry_msgs/msg/Twist', '~/cmd', qos=LATCHED)
    twist = 'RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a'
    # one counter per session: the node took 0, /rosout is not created yet, then 1, 2, 3
    expected = [
        f'@ros2_lv/0/{zid}/0/0/NN/%/%robot/talker',
        f'@ros2_lv/0/{zid}/0/1/MP/%/%robot/talker/%robot%chatter/std_msgs::msg::dds_::String_/'
        f'{H}/2::,5:,:,:,,',
        f'@ros2_lv/0/{zid}/0/2/MP/%/%robot/talker/%robot%chatter/std_msgs::msg::dds_::String_/'
        f'{H}/2::,5:,:,:,,',
        f'@ros2_lv/0/{zid}/0/3/MS/%/%robot/talker/%robot%talker%cmd/'
        f'geometry_msgs::msg::dds_::Twist_/{twist}/:1:,1:,:,:,,',
    ]
    assert wait_for(lambda: rmw_tokens(observer) == sorted(expected)), rmw_tokens(observer)
    assert pub.gid == gid(expected[1]) and second.gid == gid(expected[2])
    assert sub.gid == gid(expected[3])
    second.close()  # every entity has a token of its own: the first stays
    assert wait_for(lambda: expected[2] not in rmw_tokens(observer))
    pub.close()
    sub.close()
    assert wait_for(lambda: rmw_tokens(observer) == [expected[0]])
    node.destroy()
    assert wait_for(lambda: rmw_tokens(observer) == [])


def test_nodes_share_the_session_counter(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    shared = zros_transport()
    first = zros_node('a', transport=shared, start_parameter_services=False)
    second = zros_node('b', transport=shared, start_parameter_services=False)
    assert (first.context.wire.node.node_id, second.context.wire.node.node_id) == (0, 1)
    pub = second.create_publisher(String, 'x')
    assert pub._tokens[0].split('/')[3:5] == ['1', '2']  # node 1, entity 2


def test_keys_names_and_selection(
    zros_node: Callable[..., Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    node = zros_node('cam', '/robot', remap=['raw:=/camera/raw'])
    image = 'RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47'
    assert node.wire.name == 'rmw_zenoh' and node.scheme.domain == 0
    assert node.create_publisher('sensor_msgs/msg/Image', 'raw').key == (
        f'0/camera/raw/sensor_msgs::msg::dds_::Image_/{image}'
    )
    assert node.create_publisher(String, 'status').key == (
        f'0/robot/status/std_msgs::msg::dds_::String_/{H}'
    )
    assert node.create_service(ADD, '~/add', add).key == (
        f'0/robot/cam/add/example_interfaces::srv::dds_::AddTwoInts_/{A}'
    )
    monkeypatch.setenv('ROS_DOMAIN_ID', '7')
    assert zros_node('d').scheme.domain == 7
    assert zros_node('e', domain_id=3).create_publisher(String, 's').key.startswith('3/s/')
    monkeypatch.setenv('ROS_DOMAIN_ID', 'seven')
    with pytest.raises(ValueError, match='ROS_DOMAIN_ID'):
        zros_node('f')
    with pytest.raises(ValueError, match='domain id'):
        zros_node('g', domain_id=-1)
    monkeypatch.delenv('ROS_DOMAIN_ID')
    with pytest.raises(TypeError, match='bridge_namespace'):
        zros_node('h', bridge_namespace='/bot1')
    with pytest.raises(TypeError, match='domain_id'):
        zros_node('i', wire='bridge', domain_id=1)
    with pytest.raises(ValueError, match='wire must be'):
        zros_node('j', wire='dds')
    with pytest.raises(ValueError, match="a ROS domain id is a non-negative integer, not '3'"):
        zros_node('m', domain_id='3')
    with pytest.raises(TypeError, match='bridge_namespace= is a str, not 3'):
        zros_node('n', wire='bridge', bridge_namespace=3)
    monkeypatch.setenv('ZROS_WIRE', 'rmw_zenoh')
    assert zros_node('k', wire=None).wire.name == 'rmw_zenoh'
    monkeypatch.setenv('ZROS_WIRE', 'bridge')
    assert zros_node('l', wire=None).wire.name == 'bridge'


def test_node_wire_is_the_wire_and_compares_to_its_name_with_a_warning(
    zros_node: Callable[..., Node],
) -> None:
    node = zros_node('w')
    assert node.wire is node.context.wire
    assert (node.wire.name, str(node.wire), f'{node.wire} wire') == (
        'rmw_zenoh',
        'rmw_zenoh',
        'rmw_zenoh wire',
    )
    with pytest.warns(DeprecationWarning, match=r'compare node\.wire\.name'):
        assert node.wire == 'rmw_zenoh'
    with pytest.warns(DeprecationWarning):
        assert node.wire != 'bridge'
    assert node.wire != zros_node('v').wire and {node.wire: 1}[node.wire] == 1


def test_domains_do_not_see_each_other(zros_node: Callable[..., Node]) -> None:
    talker, listener = zros_node('talker', domain_id=1), zros_node('listener', domain_id=2)
    sub = listener.create_subscription(String, 'chatter')
    pub = talker.create_publisher(String, 'chatter')
    near = zros_node('near', domain_id=1).create_subscription(String, 'chatter')
    assert pub.wait_for_subscribers()
    pub.write(zros.Message(String, data='x'))
    assert wait_for(near.has_new_message)
    assert not sub.has_new_message() and sub.received == 0


def test_humble_keys_and_traffic(zros_node: Callable[..., Node]) -> None:
    humble = TypeRegistry(distro='humble')
    talker = zros_node('talker', registry=humble)
    listener = zros_node('listener', registry=humble)
    sub = listener.create_subscription(String, 'chatter')
    pub = talker.create_publisher(String, 'chatter')
    assert pub.key == '0/chatter/std_msgs::msg::dds_::String_/TypeHashNotSupported'
    assert pub._tokens[0].endswith('/TypeHashNotSupported/::,10:,:,:,,')
    assert pub.wait_for_subscribers()
    pub.write(zros.Message(String, data='humble'))
    assert wait_for(sub.has_new_message)
    jazzy = zros_node('jazzy').create_subscription(String, 'chatter')
    assert jazzy.key.endswith(H) and not jazzy.has_new_message()  # keys differ: never match


def test_publications_carry_the_attachment(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    pub = zros_node('talker').create_publisher(String, 'chatter')
    samples: list[Any] = []
    raw = zros_transport().session.declare_subscriber(pub.key, samples.append)
    try:
        assert pub.wait_for_subscribers()
        before = time.time_ns()
        for text in ('a', 'b', 'c'):
            pub.write(zros.Message(String, data=text))
        pub.write_raw(bytes.fromhex('00010000020000006400'))
        assert wait_for(lambda: len(samples) == 4)
        after = time.time_ns()
    finally:
        raw.undeclare()
    attachments = [Attachment.decode(s.attachment.to_bytes()) for s in samples]
    assert [a.sequence_number for a in attachments] == [1, 2, 3, 4]  # from 1, +1 each
    assert all(a.gid == pub.gid for a in attachments)
    assert all(before <= a.source_timestamp <= after for a in attachments)
    assert samples[0].payload.to_bytes() == bytes.fromhex('00010000020000006100')  # 'a'
    assert samples[3].payload.to_bytes() == bytes.fromhex('00010000020000006400')  # raw 'd'


def test_samples_without_a_valid_attachment_are_dropped(
    zros_node: Callable[..., Node],
    zros_transport: Callable[..., Transport],
    caplog: pytest.LogCaptureFixture,
) -> None:
    sub = zros_node('listener').create_subscription(String, 'chatter')
    publisher = zros_transport().session.declare_publisher(sub.key)
    good = zros.cdr.encode(zros.Message(String, data='ok'))
    assert wait_for(lambda: publisher.matching_status.matching)
    with caplog.at_level(logging.WARNING, logger='zros'):
        publisher.put(good)  # none
        publisher.put(good, attachment=b'\x01' * 10)  # malformed
        publisher.put(good, attachment=Attachment(1, 2, OTHER_GID).encode_legacy())  # legacy
        publisher.put(good, attachment=Attachment(2, 3, OTHER_GID).encode())
        assert wait_for(lambda: sub.received == 4)  # received, two of them dropped
    assert [m.data for m in sub.take()] == ['ok', 'ok']
    assert sub.unattached == sub.dropped == 2
    assert caplog.text.count('dropped a message on /chatter') == 1
    assert 'no valid rmw_zenoh attachment' in caplog.text


def test_transient_local_through_advanced_pub_sub(zros_node: Callable[..., Node]) -> None:
    talker = zros_node('talker')
    pub = talker.create_publisher(String, 'latched', qos=LATCHED)
    pub.write(zros.Message(String, data='old'))
    pub.write(zros.Message(String, data='kept'))
    late = zros_node('late').create_subscription(String, 'latched', qos=LATCHED)
    assert wait_for(late.has_new_message)
    assert [m.data for m in late.take()] == ['kept']


# --- services -----------------------------------------------------------------------------------


def test_requests_and_replies_carry_attachments(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    service = server.create_service(ADD, 'add', add)
    raw = caller.transport.session
    client = caller.create_client(ADD, 'add')
    assert client.wait_for_service()
    with spinning(server):
        for a in range(3):
            assert client.call(a=a, b=1).sum == a + 1
        # a raw request: the reply echoes its number and GID with a fresh timestamp
        request = Attachment(41, 5, OTHER_GID).encode()
        payload = bytes.fromhex('0001000002000000000000000300000000000000')
        before = time.time_ns()
        (reply,) = raw.get(
            service.key, payload=payload, attachment=request,
            target=zenoh.QueryTarget.ALL_COMPLETE, consolidation=zenoh.ConsolidationMode.NONE,
        )  # fmt: skip
    echoed = Attachment.decode(reply.ok.attachment.to_bytes())
    assert reply.ok.payload.to_bytes() == bytes.fromhex('000100000500000000000000')
    assert echoed.sequence_number == 41 and echoed.gid == OTHER_GID
    assert echoed.source_timestamp >= before
    assert Attachment.decode(client._wire.request_attachment()).gid == client.gid


def test_client_requests_are_numbered_from_one(zros_node: Callable[..., Node]) -> None:
    caller = zros_node('caller')
    client = caller.create_client(ADD, 'add')
    got: list[Attachment] = []

    def answer(query: Any) -> None:
        attachment = Attachment.decode(query.attachment.to_bytes())
        got.append(attachment)
        with query:
            query.reply(query.key_expr, bytes.fromhex('000100000500000000000000'),
                        attachment=Attachment(attachment.sequence_number, 1, attachment.gid)
                        .encode())  # fmt: skip

    queryable = zros_node('raw').transport.session.declare_queryable(
        client.key, answer, complete=True
    )
    try:
        assert client.wait_for_service()
        client.call(a=1, b=2)
        client.call_async(a=1, b=2).result(5)
    finally:
        queryable.undeclare()
    assert [a.sequence_number for a in got] == [1, 2]
    assert all(a.gid == client.gid for a in got)


def test_server_refuses_requests_rmw_zenoh_refuses(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    server = zros_node('server')
    service = server.create_service(ADD, 'add')  # polled: requests stay pending
    raw = zros_node('raw').transport.session
    payload = bytes.fromhex('0001000002000000000000000300000000000000')
    options: dict[str, Any] = {
        'target': zenoh.QueryTarget.ALL_COMPLETE,
        'consolidation': zenoh.ConsolidationMode.NONE,
    }

    def error(**extra: Any) -> str:
        (reply,) = raw.get(service.key, payload=payload, timeout=5, **options, **extra)
        assert reply.err is not None
        return str(reply.err.payload.to_string())

    with caplog.at_level(logging.WARNING, logger='zros'):
        assert 'no valid rmw_zenoh attachment' in error()
        assert 'no valid rmw_zenoh attachment' in error(attachment=b'\x00' * 5)
        assert 'negative' in error(attachment=Attachment(-1, 1, OTHER_GID).encode())
        assert 'negative' in error(attachment=Attachment(1, -1, OTHER_GID).encode())
    assert caplog.text.count('refused (reported once)') == 1
    # a pending request's number may not be used again by the same client
    first: list[Any] = []
    attachment = Attachment(7, 1, OTHER_GID).encode()
    raw.get(service.key, first.append, payload=payload, attachment=attachment, **options)
    assert service.wait_for_request(5) is not None
    assert 'repeats sequence number 7' in error(attachment=attachment)
    service.respond(service.Response(sum=5))
    assert wait_for(lambda: len(first) == 1)
    assert Attachment.decode(first[0].ok.attachment.to_bytes()).sequence_number == 7
    # answered: the number is free again
    replies: list[Any] = []
    raw.get(service.key, replies.append, payload=payload, attachment=attachment, **options)
    assert service.wait_for_request(5) is not None
    service.respond(service.Response(sum=5))
    assert wait_for(lambda: len(replies) == 1 and replies[0].ok is not None)
    assert service.failed == 5


@pytest.mark.parametrize(
    ('attachment', 'error'),
    [
        (None, 'no valid rmw_zenoh attachment'),
        (Attachment(99, 1, OTHER_GID).encode(), 'answers request 99, not request 1'),
    ],
)
def test_client_checks_the_reply_attachment(
    zros_node: Callable[..., Node], attachment: bytes | None, error: str
) -> None:
    client = zros_node('caller').create_client(ADD, 'add')

    def answer(query: Any) -> None:
        with query:
            query.reply(
                query.key_expr, bytes.fromhex('000100000500000000000000'), attachment=attachment
            )

    queryable = zros_node('raw').transport.session.declare_queryable(
        client.key, answer, complete=True
    )
    try:
        assert client.wait_for_service()
        with pytest.raises(ServiceCallError, match=error):
            client.call(a=1, b=2)
    finally:
        queryable.undeclare()


def test_incomplete_queryables_get_no_requests(zros_node: Callable[..., Node]) -> None:
    """Clients ask ALL_COMPLETE queryables, as rmw_zenoh's do: a server must be complete."""
    client = zros_node('caller').create_client(ADD, 'add')
    asked: list[Any] = []
    queryable = zros_node('raw').transport.session.declare_queryable(
        client.key, lambda q: asked.append(q) or q.drop(), complete=False
    )
    try:
        assert client.wait_for_service()  # it matches, yet is never asked
        with pytest.raises(ServiceUnavailableError):
            client.call(a=1, b=2, timeout=2)
    finally:
        queryable.undeclare()
    assert asked == []


# --- actions and the graph ----------------------------------------------------------------------


def fibonacci(goal: Any) -> Any:
    goal.publish_feedback(sequence=[0, 1])
    return goal.server.Result(sequence=[0, 1, 1])


def test_actions_are_three_services_and_two_topics(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    server = zros_node('server', '/robot', start_parameter_services=False)
    client_node = zros_node('client', start_parameter_services=False)
    server.create_action_server(FIB, 'fib', fibonacci)
    client = client_node.create_action_client(FIB, '/robot/fib')
    observer = zros_transport()

    def parts(node: str) -> set[tuple[str, str]]:
        found = set()
        for token in rmw_tokens(observer):
            chunks = token.split('/')
            if chunks[8] == node and chunks[5] != 'NN':
                found.add((chunks[5], chunks[9].replace('%robot%fib%_action%', '')))
        return found

    assert wait_for(lambda: len(parts('server')) == 5 and len(parts('client')) == 5)
    assert parts('server') == {
        ('SS', 'send_goal'), ('SS', 'cancel_goal'), ('SS', 'get_result'),
        ('MP', 'feedback'), ('MP', 'status'),
    }  # fmt: skip
    assert parts('client') == {
        ('SC', 'send_goal'), ('SC', 'cancel_goal'), ('SC', 'get_result'),
        ('MS', 'feedback'), ('MS', 'status'),
    }  # fmt: skip
    graph = graph_of(observer)
    assert graph.wait_until(lambda: graph.actions() == {'/robot/fib': [FIB]}, timeout=5)
    assert client.wait_for_server()
    handle = client.send_goal(order=2)
    assert list(handle.result(5).sequence) == [0, 1, 1]
    assert wait_for(lambda: handle.feedback is not None)


def test_the_graph_by_name_and_scheme(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    talker = zros_node('talker', '/robot')
    pub = talker.create_publisher(String, 'chatter', qos=7)
    graph = graph_of(zros_transport())
    assert graph.wait_until(lambda: '/robot/talker' in graph.nodes(), timeout=5)
    assert graph.wires() == ['rmw_zenoh']
    bridged = zros_node('old', wire='bridge')
    assert graph.wait_until(lambda: graph.wires() == ['bridge', 'rmw_zenoh'], timeout=5)
    assert '/old' in graph.nodes()
    (endpoint,) = graph.publishers(talker.scheme.key('/robot/chatter'))
    assert endpoint.wire == 'rmw_zenoh' and endpoint.node == '/robot/talker'
    assert endpoint.gid == pub.gid and endpoint.qos is not None and endpoint.qos.depth == 7
    assert endpoint.ros_name() == '/robot/chatter' and not endpoint.is_bridged
    assert graph.topics()['/robot/chatter'] == [String]
    assert talker.wait_for_publishers('chatter', timeout=5)
    assert talker.count_publishers('chatter') == 1
    assert talker.get_topic_names_and_types()
    listener = zros_node('listener')
    listener.create_subscription(String, '/robot/chatter')
    assert talker.wait_for_subscribers('chatter', timeout=5)
    assert listener.wait_for_publishers('/robot/chatter', timeout=5)
    assert ('/robot/chatter', [String]) in listener.get_topic_names_and_types()
    bridged.destroy()
    assert graph.wait_until(lambda: graph.wires() == ['rmw_zenoh'], timeout=5)


def test_the_graph_ignores_malformed_tokens(
    zros_transport: Callable[..., Transport], caplog: pytest.LogCaptureFixture
) -> None:
    graph = graph_of(zros_transport())
    other = zros_transport().session
    with caplog.at_level(logging.DEBUG, logger='zros.graph'):
        bad = other.liveliness().declare_token('@ros2_lv/0/abc/0/0/XX/%/%/n')
        good = other.liveliness().declare_token('@ros2_lv/0/abc/1/1/NN/%/%/good')
        assert graph.wait_until(lambda: '/good' in graph.nodes(), timeout=5)
        assert wait_for(lambda: 'malformed rmw_zenoh token' in caplog.text)
    assert graph.nodes() == ['/good']
    bad.undeclare()
    good.undeclare()
    assert graph.wait_until(lambda: graph.nodes() == [], timeout=5)


def test_attachment_helpers() -> None:
    from zros.keyexpr.errors import AttachmentError
    from zros.wire.rmw_zenoh_wire import SequenceNumbers, has_attachment, read_attachment

    class Carrier:
        def __init__(self, data: bytes | None) -> None:
            self.attachment = None if data is None else zenoh.ZBytes(data)

    sequence = SequenceNumbers(OTHER_GID)
    first, second = Attachment.decode(sequence.next()), Attachment.decode(sequence.next())
    assert (first.sequence_number, second.sequence_number) == (1, 2)
    assert first.gid == OTHER_GID
    with pytest.raises(AttachmentError, match='16 bytes'):
        SequenceNumbers(b'short')
    good = Attachment(3, 4, OTHER_GID)
    for data, valid in (
        (None, False),
        (good.encode(), True),
        (good.encode()[:16] + b'\x0f' + OTHER_GID, False),  # a wrong GID length byte
        (good.encode_legacy(), True),
        (b'\x00' * 77, False),
        (b'garbage', False),
    ):
        carrier = Carrier(data)
        assert has_attachment(carrier) is valid, data
        assert (read_attachment(carrier) is not None) is valid, data


def test_an_unannounced_entity_has_no_gid_to_send_with(zros_node: Callable[..., Node]) -> None:
    from zros.keyexpr.errors import AttachmentError

    wire = zros_node('tap').context.wire
    place = wire.unannounced(wire.any_type_key(wire.key('/x')))
    assert place.key == '0/x/*/*' and place.tokens == () and place.gid is None
    with pytest.raises(AttachmentError, match='has no GID to send with'):
        place.request_attachment()
