"""What ``zros foxglove`` lets a client do: which browsers may connect, under which subprotocol
name, and what a client may do to the robot (``read_only``, the topic filters)."""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable
from typing import Any

import pytest

import zros
from tests.gateway.foxglove.client import (
    LIBRARY_PROTOCOL,
    SDK_PROTOCOL,
    FoxgloveClient,
    changes_followed,
)
from zros.testing import wait_for

pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

Make = Callable[..., Any]
TIMEOUT = 20.0
TWIST = 'geometry_msgs/msg/Twist'
EVIL = 'https://evil.example'


# --- browsers ----------------------------------------------------------------------------------


def test_a_page_of_another_site_is_refused(
    gateway: Make, foxglove_client: Make, caplog: pytest.LogCaptureFixture
) -> None:
    server = gateway()
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        evil: FoxgloveClient = foxglove_client(server.url, origin=EVIL)
        assert evil.wait(lambda e: e['ev'] == 'refused')['status'] == 403
    assert not evil.of('open') and not evil.of('serverInfo')
    refusals = [r.getMessage() for r in caplog.records if EVIL in r.getMessage()]
    assert len(refusals) == 1 and '--allow-origin https://evil.example' in refusals[0]
    for origin in ('http://localhost:5173', 'http://127.0.0.1:8080', 'https://app.foxglove.dev'):
        page: FoxgloveClient = foxglove_client(server.url, origin=origin)
        assert page.server_info()['name'] == 'zros'
    program: FoxgloveClient = foxglove_client(server.url)  # no Origin: a program
    assert program.server_info()['name'] == 'zros'


def test_allowed_origins_replace_the_default(gateway: Make, foxglove_client: Make) -> None:
    server = gateway(allow_origins=[EVIL])
    allowed: FoxgloveClient = foxglove_client(server.url, origin=EVIL)
    assert allowed.server_info()['name'] == 'zros'
    app: FoxgloveClient = foxglove_client(server.url, origin='https://app.foxglove.dev')
    assert app.wait(lambda e: e['ev'] == 'refused')['status'] == 403
    everyone = gateway(allow_origins=['*'])
    assert foxglove_client(everyone.url, origin=EVIL).server_info()['name'] == 'zros'


# --- subprotocols ------------------------------------------------------------------------------


def _upgrade(port: int, protocols: str | None, origin: str | None = None) -> str:
    """The head of the server's answer to a WebSocket upgrade offering ``protocols``."""
    lines = [
        'GET / HTTP/1.1',
        f'Host: 127.0.0.1:{port}',
        'Upgrade: websocket',
        'Connection: Upgrade',
        'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==',
        'Sec-WebSocket-Version: 13',
    ]
    if protocols is not None:
        lines.append(f'Sec-WebSocket-Protocol: {protocols}')
    if origin is not None:
        lines.append(f'Origin: {origin}')
    with socket.create_connection(('127.0.0.1', port), timeout=TIMEOUT) as sock:
        sock.sendall(('\r\n'.join(lines) + '\r\n\r\n').encode())
        answer = b''
        while b'\r\n\r\n' not in answer:
            chunk = sock.recv(4096)
            if not chunk:
                break
            answer += chunk
    return answer.partition(b'\r\n\r\n')[0].decode('latin-1')


@pytest.mark.parametrize(
    ('offered', 'answered'),
    [
        (LIBRARY_PROTOCOL, LIBRARY_PROTOCOL),
        (SDK_PROTOCOL, SDK_PROTOCOL),
        (f'{LIBRARY_PROTOCOL}, {SDK_PROTOCOL}', LIBRARY_PROTOCOL),
        (f'x.other, {SDK_PROTOCOL}', SDK_PROTOCOL),
    ],
)
def test_the_answer_names_the_subprotocol_the_client_offered(
    gateway: Make, offered: str, answered: str
) -> None:
    head = _upgrade(gateway().port, offered)
    assert head.startswith('HTTP/1.1 101')
    protocols = [
        line.partition(':')[2].strip()
        for line in head.split('\r\n')
        if line.lower().startswith('sec-websocket-protocol:')
    ]
    assert protocols == [answered]


def test_an_upgrade_without_a_foxglove_subprotocol_is_refused(gateway: Make) -> None:
    port = gateway().port
    assert _upgrade(port, None).startswith('HTTP/1.1 400')
    assert _upgrade(port, 'x.other').startswith('HTTP/1.1 400')
    assert _upgrade(port, SDK_PROTOCOL, EVIL).startswith('HTTP/1.1 403')


# --- what clients may do -----------------------------------------------------------------------


def _refused_publish(server: Any, client: FoxgloveClient, zros_node: Make, why: str) -> None:
    """A client advertising /cmd_vel is told ``why`` it may not, and nothing it sends there
    reaches a zros subscriber of /cmd_vel."""
    listener = zros_node('listener')
    sub = listener.create_subscription(TWIST, '/cmd_vel', qos=100)
    start = client.mark()
    channel = client.advertise('/cmd_vel', 'cdr', TWIST)
    client.wait(lambda e: e['ev'] == 'status' and why in e['status']['message'], start=start)
    for _ in range(10):
        client.publish(channel, zros.Message(TWIST, linear={'x': 9.0}).serialize())
    # the gateway handled the advertisement (and refused it) before the status: no publisher
    assert listener.count_publishers('/cmd_vel') == 0
    assert server.clients._channels == {}
    assert sub.wait_for_message(0.5) is None


def test_a_read_only_server_lets_clients_only_watch(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    node = zros_node('pnode', start_parameter_services=True, enable_rosout=False)
    node.declare_parameter('gain', 0.5)
    node.create_service('std_srvs/srv/Trigger', '/reset', lambda request: request)
    server = gateway(read_only=True)
    client: FoxgloveClient = foxglove_client(server.url)
    capabilities = set(client.server_info()['capabilities'])
    assert not capabilities & {'clientPublish', 'services'}
    assert 'parameters' in capabilities  # to read them
    assert wait_for(
        lambda: any(p['name'] == '/pnode.gain' for p in client.get_parameters([])), TIMEOUT
    )
    start = client.mark()
    kept = client.set_parameters([{'name': '/pnode.gain', 'value': 0.75, 'type': 'float64'}])
    assert kept == [{'name': '/pnode.gain', 'value': 0.5, 'type': 'float64'}]
    assert node.get_parameter('gain') == 0.5
    client.wait(
        lambda e: e['ev'] == 'status' and 'read-only' in e['status']['message'], start=start
    )
    assert '/reset' in server._all_services() and not client.services()
    _refused_publish(server, client, zros_node, 'clientPublish')


def test_clients_publish_only_on_the_topics_offered(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    server = gateway(topics=['/chatter'])
    client: FoxgloveClient = foxglove_client(server.url)
    assert 'clientPublish' in client.server_info()['capabilities']
    _refused_publish(server, client, zros_node, 'not among the topics this server offers')


def test_a_client_advertises_a_bounded_number_of_channels(
    gateway: Make, foxglove_client: Make, zros_node: Make, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each client channel is a publisher the whole graph sees, and channels cost a client
    nothing to invent."""
    from zros.gateway.foxglove import calls

    monkeypatch.setattr(calls, 'MAX_CHANNELS', 2)
    server = gateway()
    graph = zros_node('graph_watcher')

    def published() -> list[bool]:
        return [graph.count_publishers(f'/web{index}') > 0 for index in range(4)]

    client: FoxgloveClient = foxglove_client(server.url)
    other: FoxgloveClient = foxglove_client(server.url)
    start = client.mark()
    channels = [client.advertise(f'/web{index}', 'cdr', TWIST) for index in range(3)]
    client.wait(
        lambda e: (
            e['ev'] == 'status'
            and '/web2: a client may advertise at most 2 channels at once' in e['status']['message']
        ),
        start=start,
    )
    assert wait_for(lambda: published() == [True, True, False, False], TIMEOUT), published()
    other.advertise('/web2', 'cdr', TWIST)  # the bound is each client's
    client.send('unadvertise', channelId=channels[0])
    client.advertise('/web3', 'cdr', TWIST)  # one let go is room again
    assert wait_for(lambda: published() == [False, True, True, True], TIMEOUT), published()


def test_clients_follow_a_bounded_number_of_parameters(
    gateway: Make, foxglove_client: Make, zros_node: Make, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The SDK tells the server only the union of what clients follow, and names cost a client
    nothing to invent: the server keeps at most MAX_FOLLOWED of them."""
    from zros.gateway.foxglove import params

    monkeypatch.setattr(params, 'MAX_FOLLOWED', 2)
    node = zros_node('pnode', start_parameter_services=True, enable_rosout=False)
    for name in ('a', 'b', 'c'):
        node.declare_parameter(name, 1)
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    start = client.mark()
    client.send('subscribeParameterUpdates', names=['/pnode.a', '/pnode.b', '/pnode.c'])
    client.wait(
        lambda e: e['ev'] == 'status' and '1 parameter not followed: this server follows at '
        'most 2 at once' in e['status']['message'],
        start=start,
    )  # fmt: skip
    changes_followed(client, node, 'b')
    start = client.mark()
    node.set_parameter('c', 3)
    node.set_parameter('b', 2)  # of the first two, followed
    client.wait(
        lambda e: e['ev'] == 'parameterValues'
        and {'name': '/pnode.b', 'value': 2} in e['parameters'],
        start=start,
    )  # fmt: skip
    followed = [e for e in client.events[start:] if e['ev'] == 'parameterValues']
    assert all(p['name'] == '/pnode.b' for e in followed for p in e['parameters']), followed


# --- the SDK's own log -------------------------------------------------------------------------


def test_a_client_cannot_flood_the_log_through_the_sdk(
    gateway: Make, foxglove_client: Make
) -> None:
    """The SDK logs an error per subscription to an unknown channel: 200 of them leave at most
    a burst of lines, and the server goes on answering others."""
    from zros.gateway.foxglove import sdk_logs

    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    assert client.server_info()['name'] == 'zros'
    told: list[logging.LogRecord] = []
    capture = logging.Handler()
    capture.emit = told.append  # type: ignore[method-assign]  # a handler that keeps records
    root = logging.getLogger()  # where the SDK's records end up, unbounded before
    root.addHandler(capture)
    try:
        start = client.mark()
        for channel in range(10_000, 10_200):
            client.send('subscribe', channelId=channel)
        # the SDK answers each with a status, and disconnects a client whose statuses overflow
        # its queue (DEFAULT_BACKLOG): the last status or the close ends the flood
        client.wait(
            lambda e: (
                e['ev'] == 'close'
                or (e['ev'] == 'status' and e['status']['message'].endswith(': 10199'))
            ),
            start=start,
        )
    finally:
        root.removeHandler(capture)
    unknown = [r for r in told if 'unknown channel' in r.getMessage()]
    # (none when an earlier test of this process spent this period's burst)
    assert len(unknown) <= sdk_logs.BURST, [r.getMessage() for r in unknown]
    assert foxglove_client(server.url).server_info()['name'] == 'zros'


def test_the_sdk_log_limit_tells_what_it_left_out() -> None:
    from zros.gateway.foxglove.sdk_logs import LogLimit

    now = [0.0]
    limit = LogLimit(burst=2, period=10.0, clock=lambda: now[0])

    def record(name: str = 'foxglove.websocket', level: int = logging.ERROR) -> logging.LogRecord:
        return logging.LogRecord(name, level, __file__, 1, 'bad %s', ('op',), None)

    assert [limit.filter(record()) for _ in range(5)] == [True, True, False, False, False]
    assert limit.filter(record(level=logging.WARNING))  # each level and logger has its own
    assert limit.filter(record('foxglove.other'))
    now[0] = 10.0
    told = record()
    assert limit.filter(told)
    assert told.getMessage() == 'bad op (3 more like it left out)'
    assert limit.filter(record()) and not limit.filter(record())
