"""Garbage on a live key: never new, never None, counted and reported per sender.

An attacker (or a broken peer) puts bytes that do not decode on a subscriber's key. The rosR
loop "wait for has_new_message, then read" must never read None; every reader skips the
garbage; each sender is named in the warnings and counted, and a flood costs few log lines.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import zenoh

import zros
from zros.keyexpr.attachment import Attachment
from zros.node import Node
from zros.testing import spinning, wait_for
from zros.transport import Router, Transport

Twist = 'geometry_msgs/msg/Twist'
GARBAGE = (b'garbage', b'\x00\x01\x00\x00\x01', b'\x00\x01')
_numbers = itertools.count(1)


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module runs on both wire schemes."""
    return str(request.param)


class Attacker:
    """A raw Zenoh publisher on a subscriber's key; under rmw_zenoh its puts carry a valid
    attachment with a GID of its own (garbage that passes the attachment check)."""

    def __init__(self, session: Any, subscriber: zros.Subscriber, gid: bytes) -> None:
        # reliable and blocking: Zenoh's default (drop when congested) loses some of a flood
        # on a loaded machine, and the tests count what arrived
        self.publisher = session.declare_publisher(
            subscriber.key,
            congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE,
        )
        self.attached = subscriber.node.scheme.attachments
        self.gid = gid
        assert wait_for(lambda: self.publisher.matching_status.matching)

    def put(self, payload: bytes, attached: bool = True) -> None:
        options = {}
        if self.attached and attached:
            number = next(_numbers)
            options['attachment'] = Attachment(number, time.time_ns(), self.gid).encode()
        self.publisher.put(payload, **options)


@pytest.fixture
def raw_sessions(zros_router: Router) -> Iterator[Callable[[], Any]]:
    """``open()``: a bare Zenoh client of the router that does not timestamp its samples."""
    opened: list[Any] = []

    def open_session() -> Any:
        config = zenoh.Config()
        config.insert_json5('mode', '"client"')
        config.insert_json5('connect/endpoints', f'["{zros_router.endpoint}"]')
        config.insert_json5('scouting/multicast/enabled', 'false')
        config.insert_json5('transport/shared_memory/enabled', 'false')
        session = zenoh.open(config)
        opened.append(session)
        return session

    try:
        yield open_session
    finally:
        for session in opened:
            session.close()


def good(x: float) -> bytes:
    return zros.cdr.encode(zros.Message(Twist, linear={'x': x}))


def listener_and_attacker(
    make_node: Callable[..., Node], make_transport: Callable[..., Transport], **options: Any
) -> tuple[zros.Subscriber, Attacker]:
    sub = make_node('listener').create_subscription(Twist, 'cmd_vel', **options)
    return sub, Attacker(make_transport().session, sub, bytes(range(16)))


def test_garbage_alone_never_makes_has_new_message_true(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    sub, attacker = listener_and_attacker(zros_node, zros_transport)
    for payload in GARBAGE:
        attacker.put(payload)
    assert wait_for(lambda: sub.received == len(GARBAGE))
    assert not sub.has_new_message()
    assert sub.read_message() is None
    assert sub.take() == []
    assert sub.dropped == sub.undecodable == len(GARBAGE)


def test_the_rosr_loop_never_reads_none(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    sub, attacker = listener_and_attacker(zros_node, zros_transport)
    steps: list[tuple[bytes, ...]] = [
        (GARBAGE[0],),
        (good(1.0),),
        (GARBAGE[1], GARBAGE[2]),
        (good(2.0), GARBAGE[0]),  # a good one with garbage after it
        (GARBAGE[2], good(3.0), GARBAGE[1], GARBAGE[0]),
    ]
    read = []
    sent = 0
    for step in steps:
        for payload in step:
            attacker.put(payload)
        sent += len(step)
        assert wait_for(lambda sent=sent: sub.received == sent)
        if sub.has_new_message():
            message = sub.read_message()
            assert message is not None
            read.append(message.linear.x)
    assert read == [1.0, 2.0, 3.0]
    assert not sub.has_new_message()
    if sub.node.scheme.attachments:  # garbage without an attachment never gets that far
        attacker.put(b'no attachment', attached=False)
        assert wait_for(lambda: sub.unattached == 1)
        assert not sub.has_new_message()


def test_take_and_wait_skip_garbage(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    sub, attacker = listener_and_attacker(zros_node, zros_transport, qos='keep_all')
    attacker.put(GARBAGE[0])
    attacker.put(good(1.0))
    assert wait_for(lambda: sub.received == 2)
    assert sub.has_new_message()
    assert [m.linear.x for m in sub.take(1)] == [1.0]
    for payload in (*GARBAGE, good(2.0), GARBAGE[0], good(3.0)):
        attacker.put(payload)
    assert wait_for(lambda: sub.received == 8)
    assert sub.wait_for_message(5.0).linear.x == 2.0
    assert [m.linear.x for m in sub.take(5)] == [3.0]
    assert sub.undecodable == 5


def test_callbacks_and_async_iteration_never_see_garbage(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    got: list[Any] = []
    sub, attacker = listener_and_attacker(zros_node, zros_transport, callback=got.append)
    for payload in (GARBAGE[0], good(1.0), GARBAGE[1], good(2.0)):
        attacker.put(payload)
    assert wait_for(lambda: sub.received == 4)
    with spinning(sub.node):
        assert wait_for(lambda: len(got) == 2)
    assert [m.linear.x for m in got] == [1.0, 2.0]

    polled = sub.node.create_subscription(Twist, 'cmd_vel')

    async def first_two() -> list[Any]:
        messages = []
        async for message in polled:
            messages.append(message)
            if len(messages) == 2:
                break
        return messages

    async def attack_and_read() -> list[Any]:
        reader = asyncio.ensure_future(asyncio.wait_for(first_two(), 10))
        await asyncio.sleep(0)
        for payload in (GARBAGE[2], good(3.0), GARBAGE[0], good(4.0)):
            attacker.put(payload)
        return await reader

    assert [m.linear.x for m in asyncio.run(attack_and_read())] == [3.0, 4.0]


def test_immediate_callbacks_never_see_garbage_nor_stop_at_one_that_raises(
    zros_node: Callable[..., Node],
    zros_transport: Callable[..., Transport],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Immediate callbacks decode on the delivering thread: garbage is counted and dropped there,
    and a callback that raises is logged while the next messages still reach it."""
    got: list[float] = []

    def on_message(message: Any) -> None:
        got.append(message.linear.x)
        if message.linear.x == 1.0:
            raise RuntimeError('a callback that fails once')

    def immediate(name: str) -> Node:
        return zros_node(name, immediate_callbacks=True)

    sub, attacker = listener_and_attacker(immediate, zros_transport, callback=on_message)
    with caplog.at_level(logging.ERROR, logger='zros'):
        for payload in (GARBAGE[0], good(1.0), GARBAGE[1], good(2.0), GARBAGE[2], good(3.0)):
            attacker.put(payload)
        assert wait_for(lambda: sub.received == 6 and len(got) == 3)  # nobody spins the node
    assert 'a callback that fails once' in caplog.text
    assert got == [1.0, 2.0, 3.0]
    assert sub.dropped == sub.undecodable == 3
    assert sub.read_message().linear.x == 3.0  # the last message the callback had


def test_each_attacker_is_named_and_counted(
    zros_node: Callable[..., Node],
    zros_transport: Callable[..., Transport],
    raw_sessions: Callable[[], Any],
    zros_router: Router,
    caplog: pytest.LogCaptureFixture,
) -> None:
    sub = zros_node('listener').create_subscription(Twist, 'cmd_vel', qos='keep_all')
    first = zros_transport()  # sessions that timestamp their samples (as zros and bridges do)
    second = zros_transport()
    attackers = [
        Attacker(first.session, sub, bytes([1] * 16)),
        Attacker(second.session, sub, bytes([2] * 16)),
    ]
    with caplog.at_level(logging.WARNING, logger='zros'):
        for count, attacker in zip((3, 5), attackers, strict=True):
            for _ in range(count):
                attacker.put(GARBAGE[0])
        assert wait_for(lambda: sub.received == 8)
        assert sub.take() == []
    warnings = [r.getMessage() for r in caplog.records if 'dropped a message on' in r.getMessage()]
    assert len(warnings) == 2
    if sub.node.scheme.attachments:  # rmw_zenoh: the GID of the attachment names them
        names = [f'publisher {attacker.gid.hex()}' for attacker in attackers]
    else:
        names = [f'session {first.zid}', f'session {second.zid}']
    for name in names:  # the two may arrive in either order
        (warning,) = [w for w in warnings if name in w]
        assert 'does not decode as geometry_msgs/msg/Twist' in warning
    counts = sub.dropped_by_sender()
    assert sorted(counts.values()) == [3, 5]
    assert [counts[next(k for k in counts if k.startswith(n))] for n in names] == [3, 5]

    # a sender that does not timestamp is stamped by the router: named as such, still counted
    caplog.clear()
    anonymous = Attacker(raw_sessions(), sub, bytes([3] * 16))
    with caplog.at_level(logging.WARNING, logger='zros'):
        anonymous.put(GARBAGE[1])
        assert wait_for(lambda: sub.received == 9)
        assert sub.take() == []
    if not sub.node.scheme.attachments:
        router_zid = zros_router.zid
        assert f'router {router_zid} (the sender does not timestamp' in caplog.text
    assert sum(sub.dropped_by_sender().values()) == sub.undecodable == 9


def test_a_garbage_flood_costs_a_few_log_lines(
    zros_node: Callable[..., Node],
    zros_transport: Callable[..., Transport],
    caplog: pytest.LogCaptureFixture,
) -> None:
    sub, attacker = listener_and_attacker(zros_node, zros_transport, qos='keep_all')
    flood = 5000
    with caplog.at_level(logging.WARNING, logger='zros'):
        for _ in range(flood):
            attacker.put(GARBAGE[0])
        assert wait_for(lambda: sub.received == flood, 30)
        assert not sub.has_new_message()
        assert sub.take() == []
        sub.close()
    lines = [r.getMessage() for r in caplog.records if 'on /cmd_vel' in r.getMessage()]
    assert 2 <= len(lines) <= 3  # the first, at most one summary, the rest when it closed
    assert 'before it closed' in lines[-1] and f'({flood} in all)' in lines[-1]
    assert sum(sub.dropped_by_sender().values()) == sub.dropped == flood
