"""zros across a network: two hosts in network namespaces, and a WAN with 50 ms each way."""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Iterator

import pytest

import zros
from tests.support.delay_proxy import DelayProxy
from zros.node import Node
from zros.testing import wait_for
from zros.transport import Router, Transport, TransportConfig

# --- two hosts -------------------------------------------------------------------------------

HOST_A = '169.254.91.1'
HOST_B = '169.254.91.2'


def _can_make_namespaces() -> str | None:
    if os.geteuid() != 0:
        return 'creating network namespaces needs root'
    if shutil.which('ip') is None:
        return 'the ip command (iproute2) is not installed'
    return None


@pytest.fixture
def two_hosts() -> Iterator[tuple[str, str]]:
    """Two network namespaces joined by a veth pair: ``HOST_A`` and ``HOST_B``."""
    reason = _can_make_namespaces()
    if reason:
        pytest.skip(reason)
    tag = f'{os.getpid() % 100000}'
    a, b = f'zros_a_{tag}', f'zros_b_{tag}'
    veth_a, veth_b = f'zva{tag}', f'zvb{tag}'

    def ip(*args: str) -> None:
        subprocess.run(['ip', *args], check=True, capture_output=True, timeout=10)

    try:
        ip('netns', 'add', a)
        ip('netns', 'add', b)
        ip('link', 'add', veth_a, 'type', 'veth', 'peer', 'name', veth_b)
        ip('link', 'set', veth_a, 'netns', a)
        ip('link', 'set', veth_b, 'netns', b)
        ip('-n', a, 'addr', 'add', f'{HOST_A}/24', 'dev', veth_a)
        ip('-n', b, 'addr', 'add', f'{HOST_B}/24', 'dev', veth_b)
        for namespace, veth in ((a, veth_a), (b, veth_b)):
            ip('-n', namespace, 'link', 'set', veth, 'up')
            ip('-n', namespace, 'link', 'set', 'lo', 'up')
        yield a, b
    finally:
        for namespace in (a, b):
            subprocess.run(
                ['ip', 'netns', 'del', namespace], capture_output=True, timeout=10, check=False
            )


PEER = """
import sys, time, zros
from zros.transport import TransportConfig
name, listen, connect, out_topic, in_topic = sys.argv[1:6]
# the other peer may not listen yet: open anyway, Zenoh keeps dialing
config = TransportConfig.create(mode='peer', listen=listen, connect=connect or None,
                                shared_memory=False, wait_for_router=False)
node = zros.Node(name, config=config)
sub = node.create_subscription('std_msgs/msg/String', in_topic, qos='keep_all')
# each side says when it has read everything (latched), and leaves once the other has
finished = node.create_subscription('std_msgs/msg/String', in_topic + '_done', qos='latched')
done = node.create_publisher('std_msgs/msg/String', out_topic + '_done', qos='latched')
# keep-all: every message must arrive (a keep-last publisher drops on a full link, by design)
pub = node.create_publisher('std_msgs/msg/String', out_topic, qos='keep_all')
if not pub.wait_for_subscribers(20):
    sys.exit('no subscriber showed up')
for i in range(50):
    pub.write(zros.Message('std_msgs/msg/String', data=f'{name} {i} ' + 'x' * 5000))
got = []
deadline = time.monotonic() + 20
while len(got) < 50 and time.monotonic() < deadline:
    message = sub.wait_for_message(0.5)
    if message is not None:
        got.append(int(message.data.split()[1]))
print(name, 'received', got == list(range(50)), len(got), flush=True)
done.write(zros.Message('std_msgs/msg/String', data=name))
finished.wait_for_message(20)  # the other side has read everything: the link may go
"""


def test_two_hosts_exchange_topics_both_ways(two_hosts: tuple[str, str]) -> None:
    a, b = two_hosts

    def run(namespace: str, *args: str) -> subprocess.Popen[str]:
        return subprocess.Popen(
            ['ip', 'netns', 'exec', namespace, sys.executable, '-c', PEER, *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, 'PYTHONPATH': os.pathsep.join(sys.path)},
        )

    first = run(a, 'host_a', f'tcp/{HOST_A}:7447', '', 'from_a', 'from_b')
    second = run(b, 'host_b', f'tcp/{HOST_B}:7447', f'tcp/{HOST_A}:7447', 'from_b', 'from_a')
    for process, name in ((first, 'host_a'), (second, 'host_b')):
        out, err = process.communicate(timeout=60)
        assert process.returncode == 0, err
        assert out.strip() == f'{name} received True 50'


# --- a WAN ------------------------------------------------------------------------------------


@pytest.fixture
def wan_node(zros_router: Router) -> Iterator[Callable[[str], Node]]:
    """Nodes behind a proxy that delays each direction by 50 ms."""
    host, port = zros_router.endpoint.split('/')[1].rsplit(':', 1)
    transports: list[Transport] = []
    with DelayProxy((host, int(port)), delay=0.05) as proxy:

        def make(name: str) -> Node:
            transport = Transport(
                TransportConfig.create(connect=proxy.endpoint, shared_memory=False)
            )
            transports.append(transport)
            return Node(name, transport=transport)

        try:
            yield make
        finally:
            for transport in transports:
                transport.close()


def test_wan_round_trip_and_delivery(
    wan_node: Callable[[str], Node], zros_node: Callable[..., Node]
) -> None:
    laptop = wan_node('laptop')
    robot = zros_node('robot')  # next to the router
    echo = robot.create_publisher('std_msgs/msg/Float64', 'pong')
    robot.create_subscription('std_msgs/msg/Float64', 'ping', echo.write, qos=100)
    pings = laptop.create_publisher('std_msgs/msg/Float64', 'ping')
    pongs = laptop.create_subscription('std_msgs/msg/Float64', 'pong', qos=100)
    assert pings.wait_for_subscribers(10) and echo.wait_for_subscribers(10)
    round_trips = []
    for i in range(20):
        start = time.perf_counter()
        pings.write(zros.Message('std_msgs/msg/Float64', data=float(i)))
        reply = None
        deadline = time.monotonic() + 5
        while reply is None and time.monotonic() < deadline:
            robot.spin_once(0.001)
            reply = pongs.take(1)[0] if pongs.has_new_message() else None
        assert reply is not None and reply.data == float(i)
        round_trips.append(time.perf_counter() - start)
    median = statistics.median(round_trips)
    assert 0.095 <= median <= 0.16, f'median round trip {median * 1e3:.1f} ms'
    assert wait_for(lambda: not pongs.has_new_message())
