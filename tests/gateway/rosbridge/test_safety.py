"""A rosbridge gateway safe to leave running: web pages of other sites are refused, a read-only
gateway lets clients watch and nothing more, a client cannot take over a service of the robot,
a slow client costs a bounded number of bytes, small fragments starve no one and hostile input
(client fragments by the hundred thousand, JSON nested 100,000 deep, bad TLS files) gets an
answer instead of a traceback."""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import zros
from tests.gateway.rosbridge.clients import RawClient
from tests.gateway.rosbridge.roslib_client import RoslibClient
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.views import service_providers
from zros.gateway.rosbridge.client import MAX_FRAGMENTS
from zros.testing import spinning, wait_for

Make = Callable[..., Any]
TIMEOUT = 30.0
ADD = 'example_interfaces/srv/AddTwoInts'
FIB = 'example_interfaces/action/Fibonacci'


# --- browsers ------------------------------------------------------------------------------------


def refused_status(url: str, origin: str) -> tuple[int, bytes]:
    """The HTTP status and body of an upgrade from a page of ``origin`` that is refused."""
    from websockets.exceptions import InvalidStatus

    with pytest.raises(InvalidStatus) as refused:
        RawClient(url, origin=origin)
    return refused.value.response.status_code, refused.value.response.body


def test_pages_of_other_sites_are_refused(
    rosbridge: Make, raw_client: Make, caplog: pytest.LogCaptureFixture
) -> None:
    gateway = rosbridge()
    with caplog.at_level(logging.INFO):
        status, body = refused_status(gateway.url, 'https://evil.example')
    assert status == 403 and b'--allow-origin' in body
    lines = [r for r in caplog.records if 'evil.example' in r.getMessage()]
    assert len(lines) == 1 and lines[0].levelno == logging.WARNING and lines[0].exc_info is None
    assert '--allow-origin https://evil.example' in lines[0].getMessage()
    assert not gateway.clients
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    twice = [('Origin', 'http://localhost:5173'), ('Origin', 'https://evil.example')]
    with pytest.raises(InvalidStatus) as refused:  # never judged by the first of two
        connect(gateway.url, additional_headers=twice, open_timeout=TIMEOUT)
    assert refused.value.response.status_code == 403
    # programs send no Origin; pages of this machine are the operator's
    for origin in (None, 'http://localhost:5173', 'http://127.0.0.1:8000', 'http://[::1]:3000'):
        client = raw_client(gateway, origin=origin)
        client.send(op='dance', id=str(origin))
        assert client.wait(lambda m, o=origin: m.get('id') == str(o))['op'] == 'status'


def test_clients_over_the_bound_get_503_and_a_place_frees_when_one_leaves(
    rosbridge: Make, raw_client: Make, caplog: pytest.LogCaptureFixture
) -> None:
    from websockets.exceptions import InvalidStatus

    gateway = rosbridge(max_clients=2)
    first, second = raw_client(gateway), raw_client(gateway)
    with caplog.at_level(logging.WARNING, 'zros.gateway'), pytest.raises(InvalidStatus) as refused:
        RawClient(gateway.url)
    assert refused.value.response.status_code == 503
    assert b'at most 2 clients at once (--max-clients raises it)' in refused.value.response.body
    assert 'refused 1 connection: the server serves at most 2 clients' in caplog.text
    first.close()
    assert wait_for(lambda: len(gateway.admission) == 1, TIMEOUT)
    third = raw_client(gateway)
    for client in (second, third):
        client.send(op='dance', id='still served')
        assert client.status('Unknown operation')


def test_a_client_holds_a_bounded_number_of_topics_and_services(
    rosbridge: Make, raw_client: Make, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Names cost a client nothing to invent, and each costs the gateway a Zenoh entity (a
    tap has a thread of its own; a publisher or a service shows in the whole graph)."""
    from zros.gateway.rosbridge import calls, served_actions, topics

    for module, name, value in ((topics, 'MAX_TOPICS', 3), (topics, 'MAX_REQUESTS', 2),
                                (calls, 'MAX_SERVED', 2), (served_actions, 'MAX_SERVED', 2)):  # fmt: skip
        monkeypatch.setattr(module, name, value)
    gateway = rosbridge()
    client, other = raw_client(gateway), raw_client(gateway)
    string = 'std_msgs/msg/String'
    for index in range(4):
        client.send(op='subscribe', topic=f'/t{index}', type=string, id=f's{index}')
    client.status('a client may subscribe to at most 3 topics at once: unsubscribe one first')
    for index in range(4):
        client.send(op='advertise', topic=f'/p{index}', type=string)
    client.status('a client may advertise at most 3 topics at once: unadvertise one first')
    for index in range(3):  # ids of one topic
        client.send(op='subscribe', topic='/t0', type=string, id=f'again{index}')
    client.status('at most 2 subscribe requests of one topic (/t0): unsubscribe one first')
    for index in range(3):
        client.send(op='advertise_service', service=f'/s{index}', type=ADD)
        client.send(op='advertise_action', action=f'/a{index}', type=FIB)
    client.status('a client may serve at most 2 services at once: unadvertise one first')
    client.status('a client may serve at most 2 actions at once: unadvertise one first')
    # the bounds are one client's: another has its own, and one let go is room again
    other.send(op='subscribe', topic='/t3', type=string, id='o')
    client.send(op='unsubscribe', topic='/t2')
    mark = client.mark()
    client.send(op='subscribe', topic='/t3', type=string, id='s3')
    client.send(op='dance', id='after')
    client.wait(lambda m: m.get('id') == 'after', start=mark)
    assert not [m for m in client.received[mark:] if 'at most' in str(m.get('msg'))]
    first = min(session.id for session in gateway.clients)  # the client that connected first
    assert set(gateway.topics.subscribed(first)) == {'/t0', '/t1', '/t3'}


def test_goals_to_made_up_actions_leave_nothing_behind(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge()
    watcher = zros_node('graph_watcher')
    client: RawClient = raw_client(gateway)
    count = 30
    for index in range(count):
        client.send(op='send_action_goal', id=f'g{index}', action=f'/made_up_{index}',
                    action_type=FIB, args={'order': 3})  # fmt: skip
    client.wait(lambda m: len(client.of('action_result')) == count)
    assert all(not r['result'] and 'no server' in r['values'] for r in client.of('action_result'))

    def made_up() -> list[str]:
        namespace = watcher.scheme.namespace
        return [e.ros_name(namespace) for e in watcher.graph.endpoints() if 'made_up' in e.key]

    # each goal had a client of its own, closed with it: none stays in the graph (a topic
    # advertised after them shows that the graph has caught up)
    client.send(op='advertise', topic='/marker', type='std_msgs/msg/String')
    assert wait_for(lambda: watcher.count_publishers('/marker') == 1, TIMEOUT)
    assert wait_for(lambda: not made_up(), TIMEOUT), made_up()


def test_an_action_whose_server_answered_keeps_its_client(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    from tests.actions.test_actions import fibonacci
    from zros.actions import ActionServer

    gateway = rosbridge()
    server = zros_node('hidden_server')
    # a server the graph does not show (as one not discovered yet): its answer shows it is real
    ActionServer('/hidden_fib', FIB, fibonacci, node=server, announce=False)
    watcher = zros_node('graph_watcher')
    client: RawClient = raw_client(gateway)
    with spinning(server):
        client.send(op='send_action_goal', id='g', action='/hidden_fib', action_type=FIB,
                    args={'order': 3}, feedback=True)  # fmt: skip
        result = client.wait(lambda m: m.get('op') == 'action_result')
    assert result['result'] and result['values'] == {'sequence': [0, 1, 1, 2]}

    def kept() -> list[str]:
        return [e.key for e in watcher.graph.endpoints() if 'hidden_fib' in e.key]

    # the gateway's client stays for the next goals (its feedback route is up): a topic
    # advertised after the goal ended shows that the graph has caught up
    client.send(op='advertise', topic='/marker', type='std_msgs/msg/String')
    assert wait_for(lambda: watcher.count_publishers('/marker') == 1, TIMEOUT)
    assert wait_for(kept, TIMEOUT)
    assert kept()


def test_a_client_has_a_bounded_number_of_calls_waiting(
    rosbridge: Make, raw_client: Make, zros_node: Make, monkeypatch: pytest.MonkeyPatch
) -> None:
    import threading

    from zros.gateway.rosbridge import calls

    monkeypatch.setattr(calls, 'MAX_PENDING', 2)
    gate = threading.Event()
    server = zros_node('slow_server')
    server.create_service(
        ADD, '/slow_add', lambda r: (gate.wait(TIMEOUT), service_response(server, r))[1]
    )
    gateway = rosbridge()
    client: RawClient = raw_client(gateway)
    assert wait_for(lambda: '/slow_add' in service_providers(gateway.node, ['/slow_add']), TIMEOUT)
    with spinning(server):
        for index in range(3):
            client.send(op='call_service', id=f'c{index}', service='/slow_add',
                        args={'a': index, 'b': 1})  # fmt: skip
        refused = client.wait(lambda m: m.get('id') == 'c2')
        assert refused['result'] is False
        assert refused['values'] == 'a client may have at most 2 calls and goals waiting'
        gate.set()
        answers = [client.wait(lambda m, i=i: m.get('id') == f'c{i}') for i in range(2)]
        assert [a['values'] for a in answers] == [{'sum': 1001}, {'sum': 1002}]
        client.send(op='call_service', id='after', service='/slow_add', args={'a': 5, 'b': 5})
        assert client.wait(lambda m: m.get('id') == 'after')['values'] == {'sum': 1010}


def test_a_goal_that_cannot_be_sent_frees_its_place(
    rosbridge: Make, raw_client: Make, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.actions import ActionClient, ActionError
    from zros.gateway.rosbridge import calls

    def closed(*_: object) -> None:
        raise ActionError('the action client was closed')

    monkeypatch.setattr(calls, 'MAX_PENDING', 1)
    monkeypatch.setattr(ActionClient, 'send_goal_async', closed)
    gateway = rosbridge()
    client: RawClient = raw_client(gateway)
    for index in range(3):  # the place of each failed goal is free again for the next
        client.send(op='send_action_goal', id=f'g{index}', action='/made_up', action_type=FIB,
                    args={'order': 3})  # fmt: skip
        client.wait(lambda m, i=index: m.get('id') == f'g{i}' and 'client was closed' in m['msg'])


def test_a_bound_of_clients_below_one_is_refused(rosbridge: Make) -> None:
    with pytest.raises(GatewayError, match='at least 1 client at once, not 0'):
        rosbridge(max_clients=0)


def test_allowed_origins(rosbridge: Make, raw_client: Make) -> None:
    gateway = rosbridge(allow_origins=['https://dashboard.example:8443'])
    client = raw_client(gateway, origin='https://dashboard.example:8443')
    client.send(op='dance')
    assert client.status('Unknown operation')
    assert refused_status(gateway.url, 'https://dashboard.example')[0] == 403  # another port
    everyone = rosbridge(allow_origins=['*'])
    raw_client(everyone, origin='https://evil.example').send(op='dance')


def test_roslibpy_and_roslibjs_connect(
    rosbridge: Make, roslibpy_client: Make, roslibjs: Make
) -> None:
    gateway = rosbridge()
    assert roslibpy_client(gateway).is_connected
    client: RoslibClient = roslibjs(gateway)
    assert client.wait(lambda e: e['ev'] in ('open', 'close', 'error'), TIMEOUT)['ev'] == 'open'


# --- what clients may do -------------------------------------------------------------------------


def statuses(client: RoslibClient, *words: str) -> list[dict[str, Any]]:
    """The status messages without an id roslib got that contain all ``words`` (roslib passes
    those with an id to the object that sent the op)."""
    return [e['status'] for e in client.of('status') if all(w in e['status']['msg'] for w in words)]


def service_response(node: Any, request: Any) -> Any:
    return node.registry.get_service(ADD).Response(sum=request.a + request.b + 1000)


def test_read_only_lets_clients_watch_and_nothing_more(
    rosbridge: Make, roslibjs: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge(read_only=True)
    client: RoslibClient = roslibjs(gateway)
    robot = zros_node('robot', start_parameter_services=True)
    robot.declare_parameters({'max_speed': 0.5})
    cmd_vel = robot.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    calls: list[Any] = []
    robot.create_service(ADD, '/add', lambda r: calls.append(r) or service_response(robot, r))
    goals: list[Any] = []
    robot.create_action_server(FIB, '/fibonacci', lambda g: goals.append(g) or g.server.Result())
    chatter = robot.create_publisher('std_msgs/msg/String', '/chatter')
    with spinning(robot):
        # watching: topics, rosapi, parameters read
        client.command('subscribe', topic='/chatter', type='std_msgs/msg/String')
        assert chatter.wait_for_subscribers(TIMEOUT)
        chatter.write(zros.Message('std_msgs/msg/String', data='seen'))
        assert client.wait(lambda e: e['ev'] == 'message', TIMEOUT)['msg'] == {'data': 'seen'}
        assert wait_for(lambda: '/add' in client.rosapi('getServices'), TIMEOUT)
        # acting, as roslib does it: publishing, calls, parameter sets, goals, serving
        client.command('publish', topic='/cmd_vel', type='geometry_msgs/msg/Twist',
                       msg={'linear': {'x': 1.0}})  # fmt: skip
        call = client.command('call', service='/add', type=ADD, args={'a': 1, 'b': 2})
        assert 'read-only' in client.answer(call, 'response')['error']
        param = client.command('param_set', name='/robot:max_speed', value=9.0)
        assert 'read-only' in client.answer(param, 'param_set_done')['error']
        goal = client.command('goal', action='/fibonacci', type=FIB, goal={'order': 3})
        assert client.answer(goal, 'result')['ev'] == 'failure'
        client.command('serve', service='/web_add', type=ADD)
        client.command('serve_action', action='/web_fibonacci', type=FIB)
        for op in ('advertise_service', 'advertise_action'):  # the statuses roslib shows
            assert wait_for(lambda o=op: statuses(client, f'{o}: refused', 'read-only'), TIMEOUT)
        read = client.answer(client.command('param_get', name='/robot:max_speed'), 'param')
        assert read['value'] == 0.5  # reading still works, after all of the above was refused
        # each refused op is an error status naming it, whatever the client
        raw: RawClient = raw_client(gateway)
        refused = [
            {'op': 'advertise', 'topic': '/cmd_vel', 'type': 'geometry_msgs/msg/Twist'},
            {'op': 'publish', 'topic': '/cmd_vel', 'msg': {}},
            {'op': 'call_service', 'service': '/add', 'args': {'a': 1, 'b': 2}},
            {'op': 'call_service', 'service': '/rosapi/set_param',
             'args': {'name': '/robot:max_speed', 'value': '9'}},
            {'op': 'call_service', 'service': '/rosapi/delete_param',
             'args': {'name': '/robot:max_speed'}},
            {'op': 'send_action_goal', 'action': '/fibonacci', 'action_type': FIB, 'args': {}},
            {'op': 'advertise_service', 'service': '/web_add', 'type': ADD},
            {'op': 'advertise_action', 'action': '/web_fibonacci', 'type': FIB},
        ]  # fmt: skip
        for number, op in enumerate(refused):
            raw.send(id=number, **op)
            status = raw.wait(lambda m, n=number: m.get('id') == n and m['op'] == 'status')
            assert status['level'] == 'error'
            assert (
                status['msg'].startswith(f'{op["op"]}: refused') and '--read-only' in status['msg']
            )
        # the robot saw none of it
        assert robot.get_parameter('max_speed') == 0.5
        assert not calls and not goals and cmd_vel.read_message() is None
        assert robot.count_publishers('/cmd_vel') == 0
        assert not robot.graph.services().get('/web_add')
        assert not robot.graph.actions().get('/web_fibonacci')


def test_the_topics_glob_limits_publishing(
    rosbridge: Make, roslibjs: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge(topics_glob=['/chatter'])
    client: RoslibClient = roslibjs(gateway)
    robot = zros_node('robot')
    cmd_vel = robot.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    chatter = robot.create_subscription('std_msgs/msg/String', '/chatter')
    client.command('publish', topic='/cmd_vel', type='geometry_msgs/msg/Twist',
                   msg={'linear': {'x': 1.0}})  # fmt: skip
    client.command('publish', topic='/chatter', type='std_msgs/msg/String', msg={'data': 'hi'})
    assert chatter.wait_for_message(TIMEOUT).data == 'hi'  # what the glob allows goes through
    # the gateway reads a client's ops in order: /cmd_vel was refused before /chatter went
    assert cmd_vel.read_message() is None and robot.count_publishers('/cmd_vel') == 0
    raw: RawClient = raw_client(gateway)
    raw.send(op='publish', topic='/cmd_vel', msg={}, id='p')
    assert 'not allowed here (topics glob)' in raw.wait(lambda m: m.get('id') == 'p')['msg']


@pytest.mark.parametrize('override', [False, True])
def test_a_service_of_the_graph_is_not_taken_over(
    rosbridge: Make, roslibjs: Make, zros_node: Make, override: bool
) -> None:
    gateway = rosbridge(allow_service_override=override)
    client: RoslibClient = roslibjs(gateway)
    robot = zros_node('robot')
    robot.create_service(ADD, '/reset', lambda r: service_response(robot, r))
    with spinning(robot):
        assert wait_for(lambda: '/reset' in client.rosapi('getServices'), TIMEOUT)
        client.command('serve', service='/reset', type=ADD)
        if override:  # the page serves it too: its server is on the graph
            own = gateway.node.fully_qualified_name
            assert wait_for(lambda: own in service_providers(robot, ['/reset'])['/reset'], TIMEOUT)
            assert not statuses(client, 'advertise_service')
            return
        refused = client.wait(lambda e: e['ev'] == 'status', TIMEOUT)['status']
        assert refused['level'] == 'error'
        assert 'advertise_service' in refused['msg'] and '/robot' in refused['msg']
        assert '--allow-service-override' in refused['msg']
        caller = zros_node('caller').create_client(ADD, '/reset')
        assert caller.wait_for_service(TIMEOUT)
        for a in range(10):  # the robot answers every call
            assert caller.call(a=a, b=1, timeout=TIMEOUT).sum == a + 1001
    assert not client.of('request')


def test_a_client_advertises_its_own_service_again(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge()
    client: RawClient = raw_client(gateway)
    watcher = zros_node('watcher')
    client.send(op='advertise_service', service='/mine', type=ADD, id='first')
    own = gateway.node.fully_qualified_name
    assert wait_for(lambda: service_providers(watcher, ['/mine']).get('/mine') == [own], TIMEOUT)
    client.send(op='advertise_service', service='/mine', type=ADD, id='again')  # replaced
    client.send(op='dance', id='after')
    client.wait(lambda m: m.get('id') == 'after')
    assert not client.of('status', id='first') and not client.of('status', id='again')


def test_an_action_of_the_graph_is_not_taken_over(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge()
    client: RawClient = raw_client(gateway)
    robot = zros_node('robot')
    robot.create_action_server(FIB, '/fibonacci', lambda g: g.server.Result(sequence=[7]))

    def served() -> bool:
        start = client.mark()  # each poll reads its own answer, not the first one again
        client.send(op='call_service', service='/rosapi/action_servers', id='list')
        answer = client.wait(lambda m: m.get('id') == 'list', start=start)
        return '/fibonacci' in answer['values'].get('action_servers', [])

    assert wait_for(served, TIMEOUT)
    client.send(op='advertise_action', action='/fibonacci', type=FIB, id='take')
    refused = client.wait(lambda m: m.get('id') == 'take')
    assert refused['op'] == 'status' and 'served by' in refused['msg']
    client.send(op='advertise_action', action='/web_fibonacci', type=FIB, id='mine')
    with spinning(robot):
        assert robot.create_action_client(FIB, '/web_fibonacci').wait_for_server(TIMEOUT)
    assert not client.of('status', id='mine')


# --- slow clients --------------------------------------------------------------------------------


@pytest.mark.parametrize('bound', ['bytes', 'messages'])
def test_a_slow_client_costs_its_buffer_and_never_stalls_a_fast_one(
    rosbridge: Make,
    raw_client: Make,
    zros_node: Make,
    caplog: pytest.LogCaptureFixture,
    bound: str,
) -> None:
    buffer, items = (1_000_000, 100_000) if bound == 'bytes' else (32 * 1024**2, 8)
    gateway = rosbridge(client_buffer=buffer, queue_items=items)
    slow: RawClient = raw_client(gateway, read=False)
    fast: RawClient = raw_client(gateway)
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/String', '/stream', qos=100)
    for client in (slow, fast):
        client.send(op='subscribe', topic='/stream', type='std_msgs/String')
    assert wait_for(lambda: gateway.watched() == {'/stream': 2}, TIMEOUT)
    assert pub.wait_for_subscribers(TIMEOUT)
    sessions = gateway.clients
    payload = 'z' * 100_000
    sent, started, largest, longest = 300, time.monotonic(), 0, 0
    with caplog.at_level(logging.INFO, 'zros.gateway'):
        for i in range(sent):  # in step with the fast client
            pub.write(zros.Message('std_msgs/msg/String', data=f'{i} {payload}'))
            fast.wait(
                lambda m, i=i: m.get('op') == 'publish' and m['msg']['data'].startswith(f'{i} ')
            )
            largest = max(largest, *(s.outbox.size for s in sessions))
            longest = max(longest, *(len(s.outbox) for s in sessions))
        seconds = time.monotonic() - started
        (session,) = [s for s in sessions if s.dropped]
        assert largest <= buffer and longest <= items  # never more queued for a client
        assert len(fast.of('publish')) == sent and not fast.of('status')
        slow.start()
        last = f'{sent - 1} '
        slow.wait(lambda m: m.get('op') == 'publish' and m['msg']['data'].startswith(last))
        told = slow.of('status')
        assert told and all('reads too slowly' in m['msg'] for m in told)
        assert len(told) <= seconds + 1  # at most one a second
        logged = [r.getMessage() for r in caplog.records if 'reads too slowly' in r.getMessage()]
        assert 1 <= len(logged) <= seconds + 1 and 'so far' in logged[-1]
        slow.close()
        assert wait_for(lambda: session not in gateway.clients, TIMEOUT)
    assert session.outbox.size == 0 and not len(session.outbox)  # freed when it left
    assert any(f'{session.dropped} messages were dropped' in r.getMessage() for r in caplog.records)


def test_the_default_buffer_is_32_mib(rosbridge: Make, raw_client: Make) -> None:
    gateway = rosbridge()
    raw_client(gateway).send(op='set_level', level='error')
    assert wait_for(lambda: gateway.clients, TIMEOUT)
    assert gateway.clients[0].outbox.max_bytes == 32 * 1024**2


# --- fragments -----------------------------------------------------------------------------------

FRAGMENT_READER = """
import json, sys
from websockets.sync.client import connect
with connect(sys.argv[1], max_size=None) as ws:
    ws.send(json.dumps({'op': 'subscribe', 'topic': '/camera', 'type': 'sensor_msgs/Image',
                        'fragment_size': 1}))
    count = 0
    while True:
        try:
            ws.recv(timeout=60)
        except Exception:
            break
        count += 1
        if count % 1000 == 0:
            print(count, flush=True)
"""


def image(seq: int) -> Any:
    return zros.Message(
        'sensor_msgs/msg/Image',
        header={'stamp': {'sec': seq}},
        height=1080,
        width=1920,
        encoding='rgb8',
        step=1920 * 3,
        data=np.full(1920 * 1080 * 3, seq % 251, np.uint8),
    )


def received_at_rate(pub: Any, client: RawClient, count: int, hz: float, first: int) -> int:
    """Publish ``count`` images at ``hz``; how many ``client`` received."""
    start = client.mark()
    period = 1.0 / hz
    begin = time.monotonic()
    for seq in range(first, first + count):
        pub.write(image(seq))
        delay = begin + (seq - first + 1) * period - time.monotonic()
        if delay > 0:
            time.sleep(delay)  # the publisher's pace, not a wait for the gateway
    last = first + count - 1

    def arrived() -> list[int]:
        return [
            m['msg']['header']['stamp']['sec']
            for m in client.received[start:]
            if m.get('op') == 'publish'
        ]

    wait_for(lambda: last in arrived(), 10.0)
    return len(arrived())


def test_a_tiny_fragment_size_starves_no_other_subscriber(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    gateway = rosbridge()
    other: RawClient = raw_client(gateway)
    other.send(op='subscribe', topic='/camera', type='sensor_msgs/Image', compression='cbor')
    pub = zros_node('camera').create_publisher('sensor_msgs/msg/Image', '/camera')
    assert pub.wait_for_subscribers(TIMEOUT)
    count, hz = 20, 5.0
    alone = received_at_rate(pub, other, count, hz, 1)
    assert alone >= 0.9 * count
    reader = subprocess.Popen(
        [sys.executable, '-c', FRAGMENT_READER, gateway.url], stdout=subprocess.PIPE, text=True
    )
    try:
        assert wait_for(lambda: gateway.watched() == {'/camera': 2}, TIMEOUT)
        pub.write(image(0))
        assert reader.stdout is not None and reader.stdout.readline()  # it reads fragments
        shared = received_at_rate(pub, other, count, hz, 100)
    finally:
        reader.terminate()
        reader.wait(TIMEOUT)
    assert shared >= 0.8 * alone, (shared, alone)


def test_client_fragments_are_joined_in_linear_time(rosbridge: Make, raw_client: Make) -> None:
    client: RawClient = raw_client(rosbridge())
    total = 90_000  # each put into a dict of the parts received: quadratic summing took minutes
    text = json.dumps({'op': 'dance', 'id': 'joined'})
    send = client.connection.send
    for number in range(total):
        data = text if number == total - 1 else ''
        send(
            f'{{"op":"fragment","id":"m","data":{json.dumps(data)},"num":{number},"total":{total}}}'
        )
    assert 'Unknown operation' in client.wait(lambda m: m.get('id') == 'joined', 60.0)['msg']


def test_client_fragments_are_bounded(rosbridge: Make, raw_client: Make) -> None:
    client: RawClient = raw_client(rosbridge())
    client.send(op='fragment', id='many', data='', num=0, total=MAX_FRAGMENTS + 1)
    assert (
        f'at most {MAX_FRAGMENTS} fragments' in client.wait(lambda m: m.get('id') == 'many')['msg']
    )
    inner = json.dumps({'op': 'fragment', 'id': 'inner', 'data': '{}', 'num': 0, 'total': 1})
    client.send(op='fragment', id='outer', data=inner, num=0, total=1)
    assert 'fragments of fragments' in client.wait(lambda m: m.get('id') == 'inner')['msg']
    # an id used again for another message starts that message afresh
    client.send(op='fragment', id='again', data='{"op":', num=0, total=3)
    client.send(op='fragment', id='again', data='{"op":"dance",', num=0, total=2)
    client.send(op='fragment', id='again', data='"id":"again"}', num=1, total=2)
    assert 'Unknown operation' in client.wait(lambda m: m.get('id') == 'again')['msg']
    # the oldest messages not yet whole go when the fragments held pass the message size
    small: RawClient = raw_client(rosbridge(max_message_size=100_000))
    for key in ('a', 'b', 'c'):
        small.send(op='fragment', id=key, data='x' * 40_000, num=0, total=2)
    small.send(op='fragment', id='a', data='x', num=1, total=2)  # 'a' was forgotten
    small.send(op='fragment', id='c', data='}', num=1, total=2)
    assert 'not JSON' in small.status('not JSON')['msg']  # 'c' joined
    small.send(op='dance', id='last')
    small.wait(lambda m: m.get('id') == 'last')
    assert len(small.of('status')) == 2


# --- hostile JSON --------------------------------------------------------------------------------


def test_deep_nesting_is_a_status_and_the_connection_stays(
    rosbridge: Make, raw_client: Make, zros_node: Make, caplog: pytest.LogCaptureFixture
) -> None:
    client: RawClient = raw_client(rosbridge())
    deep = '{"op":"publish","topic":"/x","msg":' + '[' * 150 + ']' * 150 + '}'
    with caplog.at_level(logging.INFO):
        for text in ('[' * 100_000, deep):
            start = client.mark()
            client.connection.send(text)
            status = client.wait(lambda m: m.get('op') in ('status', '<closed>'), start=start)
            assert 'nested deeper than 100 levels' in status['msg']
    lines = [r for r in caplog.records if 'nested deeper' in r.getMessage()]
    assert len(lines) == 2 and not [r for r in caplog.records if r.exc_info]
    pub = zros_node('talker').create_publisher('std_msgs/msg/String', '/chatter')
    client.send(op='subscribe', topic='/chatter', type='std_msgs/String')
    assert pub.wait_for_subscribers(TIMEOUT)
    pub.write(zros.Message('std_msgs/msg/String', data='still here'))
    assert client.wait(lambda m: m.get('op') == 'publish')['msg'] == {'data': 'still here'}


# --- TLS files -----------------------------------------------------------------------------------


@pytest.mark.parametrize('fault', ['missing', 'not PEM', 'not its key'])
def test_tls_files_are_named(rosbridge: Make, tmp_path: Path, fault: str) -> None:
    pytest.importorskip('cryptography', reason='certificates need the tls extra')
    from zros.transport.pki import make_certificates

    ours = make_certificates(tmp_path / 'ours')
    other = make_certificates(tmp_path / 'other')
    cert, key = str(ours.router_certificate), str(ours.router_key)
    named = cert
    if fault == 'missing':
        cert = named = str(tmp_path / 'gone.pem')
    elif fault == 'not PEM':
        key = named = str(tmp_path / 'notes.txt')
        Path(key).write_text('not a key\n')
    else:
        key = named = str(other.router_key)
    with pytest.raises(GatewayError) as refused:
        rosbridge(tls_cert=cert, tls_key=key)
    assert named in str(refused.value) and 'PEM lib' not in str(refused.value)
