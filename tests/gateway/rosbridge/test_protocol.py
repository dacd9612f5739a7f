"""The rosbridge protocol by hand (a plain WebSocket): what clients publish is checked as
rosbridge checks it, refusals come back as status messages with the op and id, subscription
options (throttle_rate, queue_length, several subscriptions of one client) behave as
rosbridge's, and the safety bounds hold (allow-lists, message size, TLS); slow clients are in
test_safety."""

from __future__ import annotations

import json
import socket
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import zros
from tests.gateway.rosbridge.clients import RawClient
from tests.gateway.rosbridge.test_values import EDGES, edges  # noqa: F401  (registers the type)
from zros.gateway.common.errors import GatewayError
from zros.testing import wait_for

Make = Callable[..., Any]
TIMEOUT = 20.0


def listener(zros_node: Make, topic: str, type_name: str) -> Any:
    node = zros_node('listener')
    return node.create_subscription(type_name, topic, qos=100)


def publish_and_read(client: RawClient, sub: Any, **op: Any) -> Any:
    assert sub.wait_for_publisher(TIMEOUT) if hasattr(sub, 'wait_for_publisher') else True
    client.send(op='publish', **op)
    return sub.wait_for_message(TIMEOUT)


def test_what_a_client_publishes_is_checked_as_rosbridge_checks_it(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge()
    client = raw_client(gateway)
    sub = listener(zros_node, '/edges_in', EDGES)
    client.send(op='advertise', topic='/edges_in', type='zros_rosbridge_tests/Edges')
    assert wait_for(lambda: sub.node.count_publishers('/edges_in') == 1, TIMEOUT)
    values = {
        'f64': 3,  # a whole number in a float field
        'data': 'AAH/',  # base64
        'data_fixed': [9, 8, 7, 6],  # or numbers
        'big': 2**63 - 1,
        'stamp': 'now',
        'text': 'ok',
    }
    client.send(op='publish', topic='/edges_in', msg=values)
    message = sub.wait_for_message(TIMEOUT)
    assert message.f64 == 3.0 and bytes(message.data) == b'\x00\x01\xff'
    assert list(message.data_fixed) == [9, 8, 7, 6] and message.big == 2**63 - 1
    assert message.stamp.sec > 1_600_000_000 and message.text == 'ok'
    assert message.f32 == 0.0 and list(message.fixed) == [0.0, 0.0, 0.0]  # defaults
    refusals = {
        'nope': ({'nope': 1}, 'does not have a field nope'),
        'int': ({'big': 1.5}, 'requires a int64 for field big, but got a number'),
        'null': ({'f64': None}, 'requires a float64 for field f64, but got null'),
        'range': ({'b': 256}, '256 is out of the range of byte'),
        'fixed': ({'fixed': [1.0]}, 'holds exactly 3 elements, not 1'),
        'base64': ({'data': '***'}, 'not valid base64'),
        'text': ({'text': 5}, 'requires a string for field text'),
        'object': (5, 'Expected a JSON object'),
    }
    for op_id, (bad, text) in refusals.items():
        start = client.mark()
        client.send(op='publish', id=op_id, topic='/edges_in', msg=bad)
        status = client.status(text, start)
        assert status['level'] == 'error' and status['id'] == op_id
        assert status['msg'].startswith('publish: ')
    assert not sub.has_new_message()  # nothing refused reached the graph


def test_a_header_without_a_stamp_gets_the_current_time(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    client = raw_client(rosbridge())
    sub = listener(zros_node, '/pose', 'geometry_msgs/msg/PoseStamped')
    client.send(op='advertise', topic='/pose', type='geometry_msgs/PoseStamped')
    assert wait_for(lambda: sub.node.count_publishers('/pose') == 1, TIMEOUT)
    client.send(op='publish', topic='/pose', msg={'header': {'frame_id': 'map'}})
    stamped = sub.wait_for_message(TIMEOUT)
    assert stamped.header.frame_id == 'map' and stamped.header.stamp.sec > 1_600_000_000
    given = {'header': {'stamp': {'secs': 5, 'nsecs': 6}}}  # rosbridge takes ROS 1's names
    client.send(op='publish', topic='/pose', msg=given)
    assert sub.wait_for_message(TIMEOUT).header.stamp.nanosec == 6
    client.send(op='publish', id=7, topic='/pose', msg={'pose': {'position': {'w': 1}}})
    status = client.status('does not have a field pose.position.w')
    assert status['msg'] == (
        'publish: Message type geometry_msgs/PoseStamped does not have a field pose.position.w'
    )


@pytest.mark.parametrize(
    ('message', 'text'),
    [
        ({'topic': '/x'}, 'Received a message without an op'),
        ({'op': 'dance'}, 'Unknown operation: dance'),
        ({'op': 'subscribe'}, 'subscribe: Expected a topic field but none was found.'),
        ({'op': 'subscribe', 'topic': 5}, 'subscribe: Expected field topic to be one of'),
        ({'op': 'subscribe', 'topic': '/x', 'throttle_rate': 'fast'}, 'throttle_rate'),
        ({'op': 'subscribe', 'topic': '/nobody'}, 'Cannot infer topic type for topic /nobody'),
        ({'op': 'subscribe', 'topic': '/x', 'type': 'no_pkg/Nothing'}, 'unknown type'),
        ({'op': 'subscribe', 'topic': 'bad name!', 'type': 'std_msgs/String'}, 'not a valid'),
        (
            {'op': 'subscribe', 'topic': '/x', 'type': 'std_msgs/String', 'compression': 'zip'},
            'unknown compression',
        ),
        ({'op': 'publish', 'topic': '/nobody', 'msg': {}}, 'Cannot infer topic type'),
        ({'op': 'advertise', 'topic': '/x', 'type': 'no_pkg/Nothing'}, 'unknown type'),
        ({'op': 'call_service', 'service': '/nobody'}, 'Service /nobody does not exist'),
        ({'op': 'service_response', 'service': '/s', 'result': True}, 'has not been advertised'),
        ({'op': 'unadvertise_service', 'service': '/s'}, 'has not been advertised'),
        ({'op': 'advertise_service', 'service': '/s', 'type': 'no/Such'}, 'unknown service type'),
        ({'op': 'cancel_action_goal', 'action': '/a', 'id': 'g'}, "no goal 'g'"),
        ({'op': 'fragment', 'id': 'f', 'data': 'x', 'num': 3, 'total': 2}, 'out of range'),
    ],
)
def test_refusals_are_status_messages(
    rosbridge: Make, raw_client: Make, message: dict[str, Any], text: str
) -> None:
    client = raw_client(rosbridge())
    if message.get('op') == 'call_service':  # the answer of a failed call is its response
        client.send(**message)
        response = client.wait(lambda m: m.get('op') == 'service_response')
        assert response['result'] is False and text in response['values']
        return
    client.send(**message)
    assert client.status(text)['level'] == 'error'


def test_not_json_and_the_status_level(rosbridge: Make, raw_client: Make) -> None:
    client = raw_client(rosbridge())
    client.connection.send('{not json')
    assert 'not JSON' in client.status('dropped')['msg']
    client.send(op='set_level', level='none')
    client.send(op='dance', id='silenced')
    client.send(op='set_level', level='warning')
    client.send(op='dance', id='told')
    assert client.status('Unknown operation')['id'] == 'told'  # the silenced one never came
    client.send(op='set_level', level='loud')  # a bad level is dropped, as the protocol says
    client.send(op='dance', id='still')
    assert client.wait(lambda m: m.get('id') == 'still')['level'] == 'error'
    # binary frames: JSON in UTF-8 is served as rosbridge_suite serves it; anything else is told
    client.connection.send(b'\x16\x00\x00\x00\x02op\x00\xff')  # BSON-like bytes
    told = client.status('binary message of 9 bytes')['msg']
    assert 'not JSON text (UTF-8)' in told and 'BSON is not served' in told
    client.connection.send(b'{"op": "dance", "id": "binary"}')
    assert client.wait(lambda m: m.get('id') == 'binary')['level'] == 'error'


def test_fragments_from_a_client_are_put_together(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    import json

    client = raw_client(rosbridge())
    sub = listener(zros_node, '/frag', 'std_msgs/msg/String')
    client.send(op='advertise', topic='/frag', type='std_msgs/String')
    assert wait_for(lambda: sub.node.count_publishers('/frag') == 1, TIMEOUT)
    text = json.dumps({'op': 'publish', 'topic': '/frag', 'msg': {'data': 'in parts'}})
    parts = [text[i : i + 10] for i in range(0, len(text), 10)]
    for number, part in reversed(list(enumerate(parts))):  # any order
        client.send(op='fragment', id='m1', data=part, num=number, total=len(parts))
    assert sub.wait_for_message(TIMEOUT).data == 'in parts'


def test_throttle_rate_and_queue_length(rosbridge: Make, raw_client: Make, zros_node: Make) -> None:
    gateway = rosbridge()
    client = raw_client(gateway)
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/Int32', '/count', qos=100)
    client.send(op='subscribe', topic='/count', type='std_msgs/Int32', throttle_rate=300)
    assert pub.wait_for_subscribers(TIMEOUT)
    started = time.monotonic()
    for i in range(20):
        pub.write(zros.Message('std_msgs/msg/Int32', data=i))

    def through() -> bool:  # one message per 300 ms passes: this one, eventually
        pub.write(zros.Message('std_msgs/msg/Int32', data=100))
        return any(m['msg']['data'] == 100 for m in client.of('publish'))

    assert wait_for(through, TIMEOUT)
    elapsed = time.monotonic() - started
    got = [m['msg']['data'] for m in client.of('publish') if m['msg']['data'] < 100]
    assert got[0] == 0 and len(got) <= 1 + elapsed / 0.3  # not 20

    queued = raw_client(gateway)
    queued.send(op='subscribe', topic='/count', throttle_rate=400, queue_length=2)
    assert wait_for(lambda: gateway.watched() == {'/count': 2}, TIMEOUT)
    for i in range(10):
        pub.write(zros.Message('std_msgs/msg/Int32', data=i))
    started = time.monotonic()
    queued.wait(lambda m: m.get('msg') == {'data': 9})  # the newest are held, then sent
    elapsed = time.monotonic() - started
    got = [m['msg']['data'] for m in queued.of('publish')]
    assert got[-2:] == [8, 9] and got == sorted(got) and len(got) <= 2 + elapsed / 0.4


def test_subscriptions_of_one_client_merge_and_taps_follow_them(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge()
    client = raw_client(gateway)
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/String', '/chatter')
    client.send(op='subscribe', topic='/chatter', id='a', type='std_msgs/msg/String')
    client.send(op='subscribe', topic='/chatter', id='b')
    client.send(op='subscribe', topic='/chatter', id='c', type='std_msgs/msg/Int32')
    # rosbridge_suite (ROS 2) names both types as the graph does: pkg/msg/Name
    assert client.status('Tried to')['msg'].endswith(
        'Tried to register topic /chatter with type std_msgs/msg/Int32 but it is already '
        'established with type std_msgs/msg/String'
    )
    assert pub.wait_for_subscribers(TIMEOUT)
    assert gateway.watched() == {'/chatter': 1}
    pub.write(zros.Message('std_msgs/msg/String', data='once'))
    client.wait(lambda m: m.get('op') == 'publish')
    client.send(op='unsubscribe', topic='/chatter', id='a')
    client.send(op='advertise', topic='/fence', type='std_msgs/String')  # answered in order
    client.send(op='subscribe', topic='/fence')
    assert wait_for(lambda: '/fence' in gateway.watched(), TIMEOUT)
    assert gateway.watched()['/chatter'] == 1  # 'b' still subscribes
    assert len(client.of('publish')) == 1  # one copy per message, not one per subscription
    client.send(op='unsubscribe', topic='/chatter', id='b')
    assert wait_for(lambda: '/chatter' not in gateway.watched(), TIMEOUT)
    assert wait_for(lambda: not pub.has_subscribers, TIMEOUT)


def test_allow_lists(rosbridge: Make, raw_client: Make, zros_node: Make) -> None:
    gateway = rosbridge(topics_glob=['/ok/*'], services_glob=['/allowed'], params_glob=['*:x'])
    client = raw_client(gateway)
    talker = zros_node('talker')
    talker.create_publisher('std_msgs/msg/String', '/ok/a')
    talker.create_publisher('std_msgs/msg/String', '/secret')
    talker.create_service('std_srvs/srv/Trigger', '/allowed', lambda r: r)
    for number, op in enumerate(
        [
            {'op': 'subscribe', 'topic': '/secret', 'type': 'std_msgs/String'},
            {'op': 'advertise', 'topic': '/secret', 'type': 'std_msgs/String'},
            {'op': 'publish', 'topic': '/secret', 'msg': {}},
            {'op': 'call_service', 'service': '/forbidden'},
            {'op': 'advertise_service', 'service': '/forbidden', 'type': 'std_srvs/Trigger'},
            {
                'op': 'send_action_goal',
                'action': '/forbidden',
                'action_type': 'example_interfaces/Fibonacci',
            },
        ]
    ):
        client.send(id=number, **op)
        assert 'is not allowed here' in client.wait(lambda m, n=number: m.get('id') == n)['msg']

    def rosapi(service: str, **args: Any) -> dict[str, Any]:
        start = client.mark()
        client.send(op='call_service', service=service, args=args, id=service)
        return client.wait(lambda m: m.get('id') == service, start=start)['values']

    assert wait_for(lambda: '/ok/a' in rosapi('/rosapi/topics')['topics'], TIMEOUT)
    assert '/secret' not in rosapi('/rosapi/topics')['topics']
    assert wait_for(lambda: rosapi('/rosapi/services')['services'] == ['/allowed'], TIMEOUT)
    refused = rosapi('/rosapi/get_param', name='/talker:y')
    assert refused['successful'] is False and 'params glob' in refused['reason']


def test_a_message_beyond_the_size_bound_closes_that_client_only(
    rosbridge: Make, raw_client: Make
) -> None:
    gateway = rosbridge(max_message_size=1000)
    greedy = raw_client(gateway)
    polite = raw_client(gateway)
    greedy.send(op='publish', topic='/x', msg={'data': 'y' * 2000})
    greedy.wait(lambda m: m.get('op') == '<closed>')
    assert greedy.connection.close_code == 1009  # message too big
    polite.send(op='dance')
    assert polite.status('Unknown operation')


def test_tls_serves_wss(tmp_path: Path, rosbridge: Make, raw_client: Make) -> None:
    pytest.importorskip('cryptography', reason='certificates need the tls extra')
    from zros.transport.pki import make_certificates

    certificates = make_certificates(tmp_path / 'pki', hosts=('127.0.0.1', 'localhost'))
    gateway = rosbridge(tls_cert=certificates.router_certificate, tls_key=certificates.router_key)
    assert gateway.url.startswith('wss://127.0.0.1:')
    client = raw_client(gateway, ca=str(certificates.ca))
    client.send(op='dance')
    assert client.status('Unknown operation')
    with pytest.raises(Exception):  # noqa: B017  the plain protocol is refused
        RawClient(gateway.url.replace('wss://', 'ws://')).send(op='dance')


@pytest.mark.parametrize(
    ('options', 'error'),
    [
        (
            {'tls_cert': '/nonexistent/cert.pem', 'tls_key': '/nonexistent/key.pem'},
            'certificate /nonexistent/cert.pem does not exist',
        ),
        ({'tls_cert': '/nonexistent/cert.pem'}, 'both a certificate and its private key'),
        ({'port': 70000}, 'the port must be 0 to 65535'),
        ({'queue_items': 0}, 'at least 1'),
    ],
)
def test_bad_settings_are_refused(rosbridge: Make, options: dict[str, Any], error: str) -> None:
    with pytest.raises(GatewayError, match=error):
        rosbridge(**options)


def test_a_port_in_use_is_refused(rosbridge: Make) -> None:
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        with pytest.raises(GatewayError, match='cannot start the rosbridge server'):
            rosbridge(port=taken.getsockname()[1])


@pytest.mark.parametrize(
    ('service', 'args', 'expected'),
    [
        ('/rosapi/get_param', {'name': 'no_colon'}, {'successful': False}),
        ('/rosapi/set_param', {'name': '/n:p', 'value': 'not json'}, {'successful': False}),
        ('/rosapi/get_param', {'name': '/nobody:p', 'default_value': '7'}, {'value': '7'}),
        ('/rosapi/has_param', {'name': '/nobody:p'}, {'exists': False}),
        ('/rosapi/delete_param', {'name': 'bad'}, {'successful': False}),
        ('/rosapi/topic_type', {'topic': '/nothing'}, {'type': ''}),
        ('/rosapi/service_type', {'service': '/nothing'}, {'type': ''}),
        ('/rosapi/service_node', {'service': '/nothing'}, {'node': ''}),
    ],
)
def test_rosapi_answers_what_it_cannot_do(
    rosbridge: Make, raw_client: Make, service: str, args: dict[str, Any], expected: dict[str, Any]
) -> None:
    client = raw_client(rosbridge())
    client.send(op='call_service', service=service, args=args, id='q')
    response = client.wait(lambda m: m.get('id') == 'q')
    assert response['result'] is True
    assert expected.items() <= response['values'].items()


@pytest.mark.parametrize(
    ('service', 'args', 'text'),
    [
        ('/rosapi/message_details', {'type': 'no_pkg/msg/Nothing'}, 'unknown type'),
        ('/rosapi/service_request_details', {'type': 'no_pkg/srv/Nothing'}, 'unknown service'),
        ('/rosapi/topic_type', {'topic': 5}, 'must be a string'),
    ],
)
def test_rosapi_failures_are_false_results(
    rosbridge: Make, raw_client: Make, service: str, args: dict[str, Any], text: str
) -> None:
    client = raw_client(rosbridge())
    client.send(op='call_service', service=service, args=args, id='q')
    response = client.wait(lambda m: m.get('id') == 'q')
    assert response['result'] is False and text in response['values']


def test_more_refusals(rosbridge: Make, raw_client: Make, zros_node: Make) -> None:
    gateway = rosbridge(max_message_size=100_000)
    client = raw_client(gateway)
    zros_node('talker').create_publisher('std_msgs/msg/Header', '/h')
    sub = listener(zros_node, '/h', 'std_msgs/msg/Header')
    client.send(op='advertise', topic='/h', type='std_msgs/Header')
    assert wait_for(lambda: sub.node.count_publishers('/h') >= 1, TIMEOUT)
    cases = [
        ({'op': 'subscribe', 'topic': '/h', 'throttle_rate': -1}, 'never negative'),
        (
            {'op': 'publish', 'topic': '/h', 'msg': {'stamp': 12}},
            'requires a builtin_interfaces/Time',
        ),
        ({'op': 'publish', 'topic': '/h', 'msg': {'stamp': {'sec': 'a'}}}, 'for field stamp.sec'),
        ({'op': 'advertise', 'topic': '/h', 'type': 'std_msgs/String'}, 'already established'),
        ({'op': 'call_service', 'service': 5}, 'Expected field service'),
        ({'op': 'call_service', 'service': '/rosapi/topics', 'args': [1]}, 'must be an object'),
        ({'op': 'fragment', 'id': 'f', 'data': 'x' * 60_000, 'num': 0, 'total': 3}, 'f'),
        ({'op': 'fragment', 'id': 'f', 'data': 'x' * 60_000, 'num': 1, 'total': 3}, 'exceed'),
    ]
    for number, (op, text) in enumerate(cases):
        start = client.mark()
        client.connection.send(json.dumps({'id': number, **op}))
        if op['op'] != 'fragment':
            assert text in client.wait(lambda m, n=number: m.get('id') == n, start=start)['msg']
    assert 'fragments of' in client.status('exceed 100000 bytes')['msg']
    client.send(op='service_response', service='/served', id='x', result=True)
    assert 'has not been advertised' in client.status('/served')['msg']
