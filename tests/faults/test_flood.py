"""A flooded subscription never delays the rest of its process.

Zenoh delivers every subscription and query of a session through one path, so a callback that
waits stalls them all. A keep-all subscription that nobody reads keeps every message up to its
memory bound, then drops (counted and logged); the recorder does the same past its queue's.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

import zros
from tests.support.processes import Script
from zros.bag.write.bag_writer import BagWriter
from zros.node import Node
from zros.qos import KEEP_ALL
from zros.testing import wait_for
from zros.transport import Router

UInt64 = 'std_msgs/msg/UInt64'
Point = 'geometry_msgs/msg/Point'
FLOOD = 50_000
STREAM = 50

FLOODER = """
import sys, zros
node = zros.Node('flooder')
pub = node.create_publisher('std_msgs/msg/UInt64', 'flood', qos='keep_all')
assert pub.wait_for_subscribers(60)
message = zros.Message('std_msgs/msg/UInt64')
print('flooding', flush=True)
for i in range({count}):
    message.data = i
    pub.write(message)
print('sent', flush=True)
sys.stdin.readline()  # until the test has every message
"""

ASKER = """
import sys, time, zros
node = zros.Node('asker')
client = node.parameter_client('/victim')
assert client.wait_for_node(60)
assert client.get('answer', timeout=30) == 42
print('ready', flush=True)
sys.stdin.readline()
started = time.monotonic()
try:
    value = client.get('answer', timeout=30)
except Exception as exc:
    value = repr(exc)
print('answer', value, time.monotonic() - started, flush=True)
"""


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module that makes nodes runs on both wire schemes."""
    return str(request.param)


@pytest.fixture
def scripts(zros_router: Router, zros_wire: str) -> Iterator[Callable[[str], Script]]:
    """``start(code)``: a script on the test's router and wire, killed at teardown."""
    started: list[Script] = []

    def start(code: str) -> Script:
        script = Script(code, zros_router, ZROS_WIRE=zros_wire)
        started.append(script)
        return script

    try:
        yield start
    finally:
        for script in started:
            script.stop()


def receive_stream(sub: zros.Subscriber, count: int, latencies: list[float]) -> None:
    """Collect ``count`` points whose ``x`` is their send time, as they arrive."""
    deadline = time.monotonic() + 60
    while len(latencies) < count and time.monotonic() < deadline:
        message = sub.wait_for_message(0.5)
        if message is not None:
            latencies.append(time.monotonic() - message.x)


def test_a_flooded_keep_all_subscription_delays_nothing_else(
    zros_node: Callable[..., Node], scripts: Callable[[str], Script]
) -> None:
    victim = zros_node('victim')
    victim.declare_parameter('answer', 42)
    flooded = victim.create_subscription(UInt64, 'flood', qos=KEEP_ALL)  # unread during the flood
    other = victim.create_subscription(Point, 'stream', qos=KEEP_ALL)
    streamer = zros_node('streamer').create_publisher(Point, 'stream', qos=KEEP_ALL)
    assert streamer.wait_for_subscribers(30)
    asker = scripts(ASKER)
    asker.expect('ready', 120)
    flooder = scripts(FLOODER.format(count=FLOOD))
    flooder.expect('flooding', 120)
    # 10,000 unread: where main's keep-all queue stopped taking and made Zenoh wait
    assert wait_for(lambda: flooded.received >= 10_000, 120)

    latencies: list[float] = []
    receiver = threading.Thread(target=receive_stream, args=(other, STREAM, latencies))
    receiver.start()
    asker.send('go')
    point = zros.Message(Point)
    for _ in range(STREAM):
        point.x = time.monotonic()
        streamer.write(point)
        time.sleep(0.01)  # a 100 Hz stream, alongside the flood
    _, answer = asker.expect('answer', 60)
    receiver.join(60)
    value, elapsed = answer.removeprefix('answer ').rsplit(' ', 1)
    worst = max(latencies, default=float('inf'))
    print(f'stream: {len(latencies)}/{STREAM}, latency max {worst:.3f} s; parameter get '
          f'{float(elapsed):.3f} s ({value})')  # fmt: skip
    assert value == '42'
    assert float(elapsed) < 1.0
    assert len(latencies) == STREAM
    assert worst < 1.0

    # below its bound a keep-all subscription loses nothing
    flooder.expect('sent', 120)
    assert wait_for(lambda: flooded.received == FLOOD, 60)
    assert [m.data for m in flooded.take()] == list(range(FLOOD))
    assert flooded.dropped == 0


def test_past_its_bound_a_keep_all_subscription_drops_and_counts(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    talker, listener = zros_node('talker'), zros_node('listener')
    bounded = zros.Subscriber('flood', UInt64, qos=KEEP_ALL, node=listener, max_queue=1000)
    small = zros.Subscriber('flood', UInt64, qos=KEEP_ALL, node=listener, max_queue_bytes=100_000)
    pub = talker.create_publisher(UInt64, 'flood', qos=KEEP_ALL)
    assert pub.wait_for_subscribers()
    message = zros.Message(UInt64)
    with caplog.at_level(logging.WARNING, logger='zros'):
        for i in range(5000):
            message.data = i
            pub.write(message)
        assert wait_for(lambda: bounded.received == small.received == 5000, 30)
    kept = [m.data for m in bounded.take()]
    assert kept == list(range(1000))  # the first ones: keep-all never replaces a message
    assert bounded.dropped == bounded.overflowed == 4000
    small_kept = [m.data for m in small.take()]
    assert small_kept == list(range(len(small_kept)))
    assert 0 < len(small_kept) < 5000 and small.dropped == 5000 - len(small_kept)
    lines = [r.getMessage() for r in caplog.records if 'keep-all queue holds' in r.getMessage()]
    first = [line for line in lines if line.startswith('dropped a message on /flood')]
    assert len(first) == 2  # one per subscription
    assert len(lines) <= 4  # and at most a summary each (one per 10 s)
    assert 'max_queue=1000' in first[0] + first[1]
    # read, they take messages again
    for i in range(10):
        message.data = i
        pub.write(message)
    assert wait_for(lambda: bounded.received == 5010)
    assert [m.data for m in bounded.take()] == list(range(10))
    assert bounded.dropped == 4000


def test_a_stalled_recorder_drops_and_counts_instead_of_stalling_its_node(
    zros_node: Callable[..., Node],
    tmp_path: Any,
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    from zros.bag import Recorder

    release = threading.Event()
    write = BagWriter.write

    def stuck_write(self: BagWriter, *args: Any) -> None:
        release.wait(120)  # a disk that does not keep up
        write(self, *args)

    monkeypatch.setattr(BagWriter, 'write', stuck_write)
    node = zros_node('recorder')
    other = node.create_subscription(UInt64, 'other', qos=KEEP_ALL)
    talker = zros_node('talker')
    pub = talker.create_publisher(UInt64, 'recorded', qos=KEEP_ALL)
    other_pub = talker.create_publisher(UInt64, 'other')
    recorder = Recorder(node, tmp_path / 'bag', topics=['/recorded'], max_queue=100)
    try:
        assert recorder.wait_for_topics(['/recorded'], 30)
        assert pub.wait_for_subscribers(30) and other_pub.wait_for_subscribers(30)
        message = zros.Message(UInt64)
        with caplog.at_level(logging.WARNING, logger='zros.bag'):
            for i in range(1000):
                message.data = i
                pub.write(message)
            for i in range(10):  # the recorder's node still hears everything else
                message.data = i
                other_pub.write(message)
            assert wait_for(lambda: other.received == 10, 10)
            assert wait_for(lambda: recorder.received == 1000, 30)
            assert recorder.dropped > 0
    finally:
        release.set()
        recorder.close()
    assert recorder.message_count + recorder.dropped == 1000
    assert any('recorder' in r.getMessage() and 'dropped' in r.getMessage() for r in caplog.records)


def test_a_bound_that_a_keep_last_subscription_would_not_use_is_refused(
    zros_node: Callable[..., Node],
) -> None:
    node = zros_node('listener')
    with pytest.raises(ValueError, match='max_queue bounds a keep-all subscriber'):
        zros.Subscriber('flood', UInt64, qos=10, node=node, max_queue=1000)
    with pytest.raises(ValueError, match='max_queue must be at least 1'):
        zros.Subscriber('flood', UInt64, qos=KEEP_ALL, node=node, max_queue=0)
