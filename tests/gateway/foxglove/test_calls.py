"""Foxglove clients acting on the graph through ``zros foxglove``: publishing (CDR and JSON),
calling services, getting, setting and following parameters, the connection graph. Both wires.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Callable
from typing import Any

import pytest

import zros
from tests.gateway.foxglove.client import FoxgloveClient, changes_followed
from zros.cdr import TypeRegistry, default_registry
from zros.cdr.message import decode, encode
from zros.cdr.render import render_bundle
from zros.gateway.common.errors import GatewayError
from zros.gateway.foxglove.calls import message_from_json
from zros.testing import spinning, wait_for

pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

Make = Callable[..., Any]
TIMEOUT = 20.0
TWIST = 'geometry_msgs/msg/Twist'


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def _publish_until_received(client: FoxgloveClient, channel: int, data: bytes, sub: Any) -> Any:
    """Publish until the subscriber has a message: the gateway's publisher and the subscriber
    find each other shortly after the advertisement."""
    for _ in range(200):
        client.publish(channel, data)
        message = sub.wait_for_message(0.1)
        if message is not None:
            return message
    raise AssertionError('nothing arrived')


def _teleop(gateway: Make, foxglove_client: Make, zros_node: Make) -> tuple[Any, Any, Any]:
    """A zros node subscribed to /cmd_vel, its subscriber, and a Foxglove client."""
    listener = zros_node('listener')
    sub = listener.create_subscription(TWIST, '/cmd_vel', qos=100)
    client: FoxgloveClient = foxglove_client(gateway().url)
    return listener, sub, client


def test_a_client_publishes_cdr_into_the_graph(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    listener, sub, client = _teleop(gateway, foxglove_client, zros_node)
    channel = client.advertise('/cmd_vel', 'cdr', TWIST)
    twist = zros.Message(TWIST, linear={'x': 0.5}, angular={'z': -1.25})
    assert _publish_until_received(client, channel, twist.serialize(), sub) == twist
    assert wait_for(lambda: listener.count_publishers('/cmd_vel') == 1, TIMEOUT)
    client.send('unadvertise', channelId=channel)
    assert wait_for(lambda: listener.count_publishers('/cmd_vel') == 0, TIMEOUT)


def test_a_client_publishes_json_into_the_graph(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    """What Foxglove's Teleop panel sends: a Twist as JSON."""
    _, sub, client = _teleop(gateway, foxglove_client, zros_node)
    channel = client.advertise('/cmd_vel', 'json', TWIST)
    text = json.dumps(
        {'linear': {'x': 1.5, 'y': 0, 'z': 0}, 'angular': {'x': 0, 'y': 0, 'z': 0.25}}
    )
    received = _publish_until_received(client, channel, text.encode(), sub)
    assert received == zros.Message(TWIST, linear={'x': 1.5}, angular={'z': 0.25})


def test_a_client_publishes_a_type_known_only_from_its_schema(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    schema = 'float64 level\nstring unit\n'
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    channel = client.advertise(
        '/tank', 'json', 'tank_msgs/msg/Level', schema=schema, schemaEncoding='ros2msg'
    )
    assert default_registry().find('tank_msgs/msg/Level') is None  # the process's: untouched
    listener = zros_node('listener', registry=TypeRegistry())
    listener.registry.register_text('tank_msgs/msg/Level', schema)
    sub = listener.create_subscription('tank_msgs/msg/Level', '/tank')
    received = _publish_until_received(client, channel, b'{"level": 0.75, "unit": "m"}', sub)
    assert (received.level, received.unit) == (0.75, 'm')


def _told(client: FoxgloveClient, text: str, start: int) -> None:
    """Wait for a status whose message holds ``text``."""
    client.wait(lambda e: e['ev'] == 'status' and text in e['status']['message'], start=start)


def test_bad_client_data_never_reaches_the_graph(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    listener, sub, client = _teleop(gateway, foxglove_client, zros_node)
    client.server_info()
    start = client.mark()
    refused = [
        (('/x', 'cdr', 'no_such_pkg/msg/Thing'), {}, 'unknown type no_such_pkg'),
        (('/y', 'protobuf', TWIST), {}, "'protobuf' is not one of"),
        (
            ('/z', 'cdr', 'no_such_pkg/msg/Thing'),
            {'schema': 'float64 x y z', 'schemaEncoding': 'ros2msg'},
            'the schema of no_such_pkg/msg/Thing is unusable',
        ),
        (('/bad topic!', 'cdr', TWIST), {}, 'cannot publish on /bad topic!'),
    ]
    for args, extra, reason in refused:
        client.advertise(*args, **extra)
        _told(client, reason, start)
    cdr = client.advertise('/cmd_vel', 'cdr', TWIST)
    assert wait_for(lambda: listener.count_publishers('/cmd_vel') == 1, TIMEOUT)
    client.publish(cdr, b'\x00\x01\x00\x00\x01')  # a Twist is 48 bytes of doubles
    _told(client, 'on /cmd_vel was not published', start)
    text = client.advertise('/cmd_vel', 'json', TWIST)
    client.publish(text, b'{"linear": {"w": 1}}')
    _told(client, "has no field 'linear.w'", start)
    client.publish(text, b'not json')
    good = zros.Message(TWIST, linear={'x': 2.0})
    assert _publish_until_received(client, cdr, good.serialize(), sub) == good
    assert sub.take() == []  # nothing else came through


def test_a_type_other_than_the_topics_is_refused(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    """A client advertising Int32 on a String topic is told, and nothing it sends on that
    channel reaches the graph; the topic's own type still goes through."""
    talker = zros_node('talker')
    talker.create_publisher('std_msgs/msg/String', '/chatter')
    listener = zros_node('listener')
    right = listener.create_subscription('std_msgs/msg/String', '/chatter', qos=100)
    client: FoxgloveClient = foxglove_client(gateway().url)
    client.channel('/chatter')  # the gateway knows the topic's type
    start = client.mark()
    refused = client.advertise('/chatter', 'json', 'std_msgs/msg/Int32')
    _told(
        client,
        '/chatter: refused to publish std_msgs/msg/Int32, the topic has type std_msgs/msg/String',
        start,
    )
    for n in range(20):
        client.publish(refused, json.dumps({'data': n}).encode())
    channel = client.advertise('/chatter', 'json', 'std_msgs/msg/String')
    received = _publish_until_received(client, channel, b'{"data": "hi"}', right)
    assert received.data == 'hi'
    assert {m.data for m in right.take()} <= {'hi'}  # no Int32 bytes read as a String
    # the talker and the String channel
    assert wait_for(lambda: listener.count_publishers('/chatter') == 2, TIMEOUT)
    assert dict(listener.get_topic_names_and_types())['/chatter'] == ['std_msgs/msg/String']


def test_services_are_offered_and_called(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    server_node = zros_node('adder')

    def add(request: Any, response: Any) -> Any:
        response.sum = request.a + request.b
        return response

    server_node.create_service('example_interfaces/srv/AddTwoInts', '/add_two_ints', add)

    def fail(request: Any) -> Any:
        raise RuntimeError('always fails')

    server_node.create_service('std_srvs/srv/Trigger', '/broken', fail)
    srv = default_registry().get_service('example_interfaces/srv/AddTwoInts')
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    with spinning(server_node):
        client.wait(lambda e: {'/add_two_ints', '/broken'} <= set(client.services()))
        service = client.services()['/add_two_ints']
        assert service['type'] == 'example_interfaces/srv/AddTwoInts'
        for part, type_name in (('request', srv.Request), ('response', srv.Response)):
            assert service[part] == {
                'encoding': 'cdr',
                'schemaName': type_name.__msgtype__,
                'schemaEncoding': 'ros2msg',
                'schema': render_bundle(default_registry(), type_name.__msgtype__),
            }
        response = client.call_service('/add_two_ints', encode(srv.Request(a=2, b=40)))
        assert response['ev'] == 'serviceCallResponse', response
        assert decode(srv.Response, base64.b64decode(response['data'])).sum == 42
        failure = client.call_service('/broken', b'\x00\x01\x00\x00\x00')
        assert failure['ev'] == 'serviceCallFailure'
        assert 'always fails' in failure['message']
        garbage = client.call_service('/add_two_ints', b'\x00\x01\x00\x00\x07')
        assert garbage['ev'] == 'serviceCallFailure'
        assert 'does not decode' in garbage['message']
        # the request schema says CDR: a call in JSON is refused, and the server keeps serving
        text = client.call_service('/add_two_ints', b'{"a": 2, "b": 40}', encoding='json')
        assert text['ev'] == 'serviceCallFailure' and 'encoding' in text['message'], text
        again = client.call_service('/add_two_ints', encode(srv.Request(a=1, b=1)))
        assert decode(srv.Response, base64.b64decode(again['data'])).sum == 2
    assert not any('/zros_foxglove' in name for name in client.services())


def test_parameters_of_a_zros_node(gateway: Make, foxglove_client: Make, zros_node: Make) -> None:
    node = zros_node('pnode', start_parameter_services=True, enable_rosout=False)
    node.declare_parameter('gain', 0.5, floating_point_range=(0.0, 1.0, 0.0))
    node.declare_parameter('count', 4)
    node.declare_parameter('name', 'arm')
    node.declare_parameter('ids', [1, 2, 3])
    node.declare_parameter('blob', b'\x00\xff')
    node.declare_parameter('weights', [0.5, 1.0])
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    assert {'parameters', 'parametersSubscribe'} <= set(client.server_info()['capabilities'])
    values: dict[str, Any] = {}

    def listed() -> bool:  # once the gateway sees the node's parameter services
        values.update({p['name']: p for p in client.get_parameters([])})
        return '/pnode.gain' in values

    assert wait_for(listed, TIMEOUT)
    assert values['/pnode.gain'] == {'name': '/pnode.gain', 'value': 0.5, 'type': 'float64'}
    assert values['/pnode.count']['value'] == 4 and 'type' not in values['/pnode.count']
    assert values['/pnode.name']['value'] == 'arm'
    assert values['/pnode.ids']['value'] == [1, 2, 3]
    assert values['/pnode.blob'] == {'name': '/pnode.blob', 'value': 'AP8=', 'type': 'byte_array'}
    assert values['/pnode.weights'] == {
        'name': '/pnode.weights',
        'value': [0.5, 1],
        'type': 'float64_array',
    }
    assert '/pnode.use_sim_time' in values
    assert [p['name'] for p in client.get_parameters(['/pnode.count'])] == ['/pnode.count']
    client.send('subscribeParameterUpdates', names=['/pnode.gain', '/pnode.count'])
    start = client.mark()
    updated = client.set_parameters(
        [
            {'name': '/pnode.gain', 'value': 0.75, 'type': 'float64'},
            {'name': '/pnode.count', 'value': 6},
        ]
    )
    assert {p['name']: p['value'] for p in updated} == {'/pnode.gain': 0.75, '/pnode.count': 6}
    assert node.get_parameter('gain') == 0.75 and node.get_parameter('count') == 6
    refused = client.set_parameters([{'name': '/pnode.gain', 'value': 7.0, 'type': 'float64'}])
    assert refused == [{'name': '/pnode.gain', 'value': 0.75, 'type': 'float64'}]
    client.wait(
        lambda e: e['ev'] == 'status' and 'refused gain' in e['status']['message'], start=start
    )
    start = client.mark()
    client.set_parameters([{'name': '/pnode.count', 'value': {'a': 1}}])  # no parameter's value
    client.wait(
        lambda e: e['ev'] == 'status' and 'cannot set /pnode.count' in e['status']['message'],
        start=start,
    )
    assert node.get_parameter('count') == 6
    start = client.mark()
    node.set_parameter('count', 8)  # the node changes it: the client is told
    client.wait(
        lambda e: (
            e['ev'] == 'parameterValues'
            and 'id' not in e
            and {'name': '/pnode.count', 'value': 8} in e['parameters']
        ),
        start=start,
    )


def test_the_connection_graph(gateway: Make, foxglove_client: Make, zros_node: Make) -> None:
    talker = zros_node('talker')
    talker.create_publisher('std_msgs/msg/String', '/chatter')
    listener = zros_node('listener')
    listener.create_subscription('std_msgs/msg/String', '/chatter')
    adder = zros_node('adder')
    adder.create_service('example_interfaces/srv/AddTwoInts', '/add_two_ints')
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    client.send('subscribeConnectionGraph')

    def complete(event: dict[str, Any]) -> bool:
        if event['ev'] != 'connectionGraphUpdate':
            return False
        published = {t['name']: t['publisherIds'] for t in event['publishedTopics']}
        subscribed = {t['name']: t['subscriberIds'] for t in event['subscribedTopics']}
        services = {s['name']: s['providerIds'] for s in event['advertisedServices']}
        return (
            published.get('/chatter') == ['/talker']
            and subscribed.get('/chatter') == ['/listener']
            and services.get('/add_two_ints') == ['/adder']
        )

    client.wait(complete)


def test_services_and_parameters_are_selected_by_regex(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    node = zros_node('pnode', start_parameter_services=True, enable_rosout=False)
    node.declare_parameter('gain', 0.5)
    node.declare_parameter('count', 4)
    node.create_service('example_interfaces/srv/AddTwoInts', '/add_two_ints')
    node.create_service('std_srvs/srv/Trigger', '/reset')
    server = gateway(services=['/add_.*'], params=[r'/pnode\.gain'])
    client: FoxgloveClient = foxglove_client(server.url)
    client.wait(lambda e: '/add_two_ints' in client.services())
    assert set(client.services()) == {'/add_two_ints'}  # not /reset, nor the parameter services
    found: list[dict[str, Any]] = []

    def listed() -> bool:
        found[:] = client.get_parameters([])
        return bool(found)

    assert wait_for(listed, TIMEOUT)
    assert [p['name'] for p in found] == ['/pnode.gain']
    assert client.get_parameters(['/pnode.count']) == []
    start = client.mark()
    assert client.set_parameters([{'name': '/pnode.count', 'value': 5}]) == []
    _told(client, 'the parameter /pnode.count may not be set through this server', start)
    assert node.get_parameter('count') == 4
    # nor followed: its changes are not sent (they would come before the later change of gain)
    start = client.mark()
    client.send('subscribeParameterUpdates', names=['/pnode.gain', '/pnode.count'])
    _told(client, '1 parameter may not be followed through this server (/pnode.count)', start)
    changes_followed(client, node, 'gain')
    start = client.mark()
    node.set_parameter('count', 9)
    node.set_parameter('gain', 0.25)
    client.wait(
        lambda e: e['ev'] == 'parameterValues' and 'id' not in e
        and {'name': '/pnode.gain', 'value': 0.25, 'type': 'float64'} in e['parameters'],
        start=start,
    )  # fmt: skip
    followed = [e for e in client.events[start:] if e['ev'] == 'parameterValues']
    assert all(p['name'] == '/pnode.gain' for e in followed for p in e['parameters']), followed


def test_unknown_nodes_and_service_types(
    gateway: Make, foxglove_client: Make, zros_node: Make, caplog: pytest.LogCaptureFixture
) -> None:
    """A service whose type the gateway does not know is not offered (zros could not call it);
    parameters of a node that is not there are told, not waited for."""
    from zros.cdr import TypeRegistry

    own_types = TypeRegistry()
    own_types.register_text('tank_msgs/srv/Fill', 'float64 litres\n---\nbool done\n')
    custom = zros_node('tank', registry=own_types)
    custom.create_service('tank_msgs/srv/Fill', '/fill')
    custom.create_service('std_srvs/srv/Trigger', '/drain')
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    client.wait(lambda e: '/drain' in client.services())
    assert '/fill' not in client.services()
    assert 'no definition of tank_msgs/srv/Fill_Request' in caplog.text
    start = client.mark()
    assert client.set_parameters([{'name': '/ghost.speed', 'value': 1}]) == []
    _told(client, 'cannot set parameters of /ghost', start)
    assert client.get_parameters(['/ghost.speed']) == []
    assert 'no parameters from /ghost' in caplog.text


def test_messages_from_json() -> None:
    Twist = type(zros.Message('geometry_msgs/msg/Twist'))
    twist = message_from_json(Twist, '{"linear": {"x": 1}, "angular": {"z": -2.5}}')
    assert (twist.linear.x, twist.angular.z) == (1.0, -2.5)
    for text, error in (
        ('[1, 2]', 'needs a mapping'),
        ('{"spin": 1}', "no field 'spin'"),
        ('{', 'cannot make'),
    ):
        with pytest.raises(GatewayError, match=error):
            message_from_json(Twist, text)
