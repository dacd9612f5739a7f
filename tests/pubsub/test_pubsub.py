"""Publishers, subscribers, callbacks, polling, asyncio and transient local, in one process."""

from __future__ import annotations

import asyncio
import gc
import logging
import time
import weakref
from collections.abc import Callable
from datetime import datetime, timezone
from functools import partial

import numpy as np
import pytest
import zenoh

import zros
from tests.support.races import close_while_used
from tests.support.wire_support import put_options
from zros.node import Node
from zros.qos import LATCHED, QoS
from zros.testing import wait_for
from zros.transport import Transport


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module that makes nodes runs on both wire schemes."""
    return str(request.param)


String = 'std_msgs/msg/String'


def text(value: str) -> zros.cdr.Message:
    return zros.Message(String, data=value)


def connected(make: Callable[..., Node]) -> tuple[Node, Node]:
    return make('talker'), make('listener')


def test_callbacks_run_in_spin_once_in_order(zros_node: Callable[..., Node]) -> None:
    talker, listener = connected(zros_node)
    got: list[str] = []
    listener.create_subscription(String, 'chatter', lambda m: got.append(m.data), qos=100)
    pub = talker.create_publisher(String, '/chatter')
    assert pub.wait_for_subscribers()
    for i in range(20):
        pub.write(text(f'hello {i}'))
    assert got == []  # nothing runs on Zenoh's threads
    assert wait_for(lambda: listener.spin_once(0.05) >= 0 and len(got) == 20)
    assert got == [f'hello {i}' for i in range(20)]


def test_polling_read_and_take(zros_node: Callable[..., Node]) -> None:
    talker, listener = connected(zros_node)
    sub = zros.Subscriber('chatter', String, node=listener, qos=10)
    pub = zros.Publisher('chatter', String, node=talker)
    assert sub.read_message() is None and not sub.has_new_message()
    assert pub.wait_for_subscribers()
    for i in range(25):
        pub.write(text(str(i)))
    assert wait_for(lambda: sub.received == 25)
    assert sub.has_new_message()
    assert sub.read_message().data == '24'  # rosR semantics: the newest
    assert not sub.has_new_message()
    assert sub.read_message().data == '24'  # still the last one read
    for i in range(25, 30):
        pub.write(text(str(i)))
    assert wait_for(lambda: sub.received == 30)
    assert [m.data for m in sub.take()] == ['25', '26', '27', '28', '29']
    assert sub.take() == []
    for i in range(30, 35):
        pub.write(text(str(i)))
    assert wait_for(lambda: sub.received == 35)
    assert sub.has_new_message()  # decodes the newest; take() still gives every one, in order
    assert [m.data for m in sub.take()] == ['30', '31', '32', '33', '34']
    assert not sub.has_new_message()


def test_wait_for_message_at_its_edges(zros_node: Callable[..., Node]) -> None:
    """The oldest unread message, at once when one is there (even with no time left, and once
    the subscriber is closed); None when none comes in time, or after close."""
    talker, listener = connected(zros_node)
    sub = zros.Subscriber('chatter', String, node=listener, qos=10)
    pub = zros.Publisher('chatter', String, node=talker)
    assert pub.wait_for_subscribers()
    start = time.monotonic()
    assert sub.wait_for_message(0.2) is None
    assert time.monotonic() - start >= 0.2
    assert sub.wait_for_message(0) is None
    for i in range(3):
        pub.write(text(str(i)))
    assert wait_for(lambda: sub.received == 3)
    assert sub.wait_for_message(0).data == '0'
    assert sub.wait_for_message(5).data == '1'
    sub.close()
    assert sub.wait_for_message(5).data == '2'  # read after close: still there
    start = time.monotonic()
    assert sub.wait_for_message(5) is None
    assert time.monotonic() - start < 2


def test_read_message_reads_the_state_and_wait_for_message_the_stream(
    zros_node: Callable[..., Node],
) -> None:
    """The one rule of the reads: ``read_message`` gives the newest and drops older unread
    messages (rosR); ``take`` and ``wait_for_message`` give the oldest unread, each once."""
    talker, listener = connected(zros_node)
    sub = zros.Subscriber('chatter', String, node=listener, qos=10)
    pub = zros.Publisher('chatter', String, node=talker)
    assert pub.wait_for_subscribers()
    for i in range(4):
        pub.write(text(str(i)))
    assert wait_for(lambda: sub.received == 4)
    assert sub.wait_for_message(5).data == '0'  # the stream: the oldest unread
    assert [m.data for m in sub.take(1)] == ['1']
    assert sub.read_message().data == '3'  # the state: the newest; '2' is dropped unread
    assert sub.wait_for_message(0) is None and sub.take() == []
    assert sub.read_message().data == '3'  # the state stays until a newer one comes


def test_messages_small_and_large_in_turn_arrive_intact(zros_node: Callable[..., Node]) -> None:
    talker, listener = connected(zros_node)
    kind = 'std_msgs/msg/UInt8MultiArray'
    sub = listener.create_subscription(kind, 'blobs', qos='keep_all')
    pub = talker.create_publisher(kind, 'blobs', qos='keep_all')
    assert pub.wait_for_subscribers(30)
    rng = np.random.default_rng(7)
    sizes = [10, 200_000, 70_000, 10, 5, 300_000, 100_000, 20]  # large ones reuse a buffer
    sent = [rng.integers(0, 256, size, dtype=np.uint8) for size in sizes]
    for data in sent:
        pub.write(zros.Message(kind, data=data))
    assert wait_for(lambda: sub.received == len(sent), 30)
    got = sub.take()
    assert len(got) == len(sent)
    for message, data in zip(got, sent, strict=True):
        assert np.array_equal(message.data, data)


def test_keep_last_keeps_the_newest(zros_node: Callable[..., Node]) -> None:
    talker, listener = connected(zros_node)
    sub = listener.create_subscription(String, 'chatter', qos=QoS(10))
    pub = talker.create_publisher(String, 'chatter')
    assert pub.wait_for_subscribers()
    for i in range(500):
        pub.write(text(str(i)))
        if i % 50 == 49:
            assert wait_for(lambda i=i: sub.received == i + 1)
            assert sub.read_message().data == str(i)
    assert wait_for(lambda: sub.received == 500)
    for i in range(100):
        pub.write(text(f'x{i}'))
    assert wait_for(lambda: sub.received == 600)
    assert [m.data for m in sub.take()] == [f'x{i}' for i in range(90, 100)]


def test_first_message_after_matching_arrives_quickly(zros_node: Callable[..., Node]) -> None:
    talker, listener = connected(zros_node)
    sub = listener.create_subscription(String, 'first')
    pub = talker.create_publisher(String, 'first')
    assert pub.wait_for_subscribers()
    start = time.perf_counter()
    pub.write(text('first'))
    message = sub.wait_for_message(timeout=1.0)
    elapsed = time.perf_counter() - start
    assert message is not None and message.data == 'first'
    assert elapsed < 0.05, f'{elapsed * 1e3:.1f} ms'


def test_a_raising_callback_is_logged_and_the_node_goes_on(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    talker, listener = connected(zros_node)
    got: list[str] = []

    def fragile(message: zros.cdr.Message) -> None:
        if message.data == 'boom':
            raise RuntimeError('callback failure')
        got.append(message.data)

    listener.create_subscription(String, 'chatter', fragile)
    pub = talker.create_publisher(String, 'chatter')
    assert pub.wait_for_subscribers()
    for data in ('a', 'boom', 'b'):
        pub.write(text(data))
    with caplog.at_level(logging.ERROR, logger='zros'):
        assert wait_for(lambda: listener.spin_once(0.05) >= 0 and len(got) == 2)
    assert got == ['a', 'b']
    assert 'callback failure' in caplog.text and 'Traceback' in caplog.text
    assert listener.ok()


def test_malformed_payloads_are_logged_once_per_publisher_and_dropped(
    zros_node: Callable[..., Node],
    zros_transport: Callable[..., Transport],
    caplog: pytest.LogCaptureFixture,
) -> None:
    _, listener = connected(zros_node)
    sub = listener.create_subscription('geometry_msgs/msg/Twist', 'cmd_vel')
    rogue = zros_transport()
    publisher = rogue.session.declare_publisher(sub.key)
    assert wait_for(lambda: publisher.matching_status.matching)
    good = zros.cdr.encode(zros.Message('geometry_msgs/msg/Twist', linear={'x': 1.0}))
    with caplog.at_level(logging.WARNING, logger='zros'):
        for payload in (b'garbage', good, b'\x00\x01\x00\x00\x01', good[:20], good):
            publisher.put(payload, **put_options(listener))
        assert wait_for(lambda: sub.received == 5)
        messages = sub.take()
    assert [m.linear.x for m in messages] == [1.0, 1.0]
    assert sub.dropped == 3
    warnings = [r for r in caplog.records if 'dropped a message on /cmd_vel' in r.getMessage()]
    assert len(warnings) == 1
    assert rogue.zid in warnings[0].getMessage()


def test_write_checks_the_type(zros_node: Callable[..., Node]) -> None:
    talker = zros_node('talker')
    pub = talker.create_publisher(String, 'chatter')
    with pytest.raises(TypeError, match='sends std_msgs/msg/String, not std_msgs/msg/Bool'):
        pub.write(zros.Message('std_msgs/msg/Bool'))
    broken = text('x')
    broken.data = 5  # type: ignore[attr-defined]
    with pytest.raises(zros.CdrError, match="field 'data'"):
        pub.write(broken)


@pytest.mark.parametrize('zros_wire', ['bridge'])  # rmw_zenoh: tests/rmw/test_runtime.py
def test_tokens_live_exactly_as_long_as_their_entities(
    zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    node = zros_node('talker', '/robot', start_parameter_services=False)  # only its topics
    observer = zros_transport()

    def tokens() -> list[str]:
        return sorted(
            str(r.ok.key_expr) for r in observer.session.liveliness().get('@/*/@ros2_lv/**') if r.ok
        )

    zid = node.transport.zid
    pub = node.create_publisher(String, 'chatter', qos='sensor_data')
    second = node.create_publisher(String, 'chatter', qos='sensor_data')
    sub = node.create_subscription('geometry_msgs/msg/Twist', '~/cmd', qos=LATCHED)
    expected = [
        f'@/{zid}/@ros2_lv/MP/robot\u00a7chatter/std_msgs\u00a7msg\u00a7String/:0:0:0,5',
        f'@/{zid}/@ros2_lv/MS/robot\u00a7talker\u00a7cmd/geometry_msgs\u00a7msg\u00a7Twist/:1:1:0,1',
    ]
    assert wait_for(lambda: tokens() == expected)
    second.close()  # one token per (kind, key) and session: it stays while pub lives
    pub.write(text('still announced'))
    assert tokens() == expected
    pub.close()
    sub.close()
    assert wait_for(lambda: tokens() == [])


@pytest.mark.parametrize('zros_wire', ['bridge'])  # rmw_zenoh: tests/rmw/test_runtime.py
def test_names_namespaces_remapping_and_bridge_namespace(zros_node: Callable[..., Node]) -> None:
    node = zros_node('cam', '/robot', remap=['raw:=/camera/raw'], bridge_namespace='/bot1')
    assert node.fully_qualified_name == '/robot/cam'
    assert node.create_publisher('sensor_msgs/msg/Image', 'raw').key == 'bot1/camera/raw'
    assert node.create_publisher(String, 'status').key == 'bot1/robot/status'
    assert node.create_publisher(String, '~/log').topic == '/robot/cam/log'
    from_args = zros_node(
        'x', args=['prog', '--ros-args', '-r', '__node:=renamed', '-r', '__ns:=/ns']
    )
    assert from_args.fully_qualified_name == '/ns/renamed'
    with pytest.raises(zros.InvalidNameError, match='must not end with "/"'):
        node.create_publisher(String, 'bad/')


def test_transient_local_history_reaches_late_subscribers_once(
    zros_node: Callable[..., Node],
) -> None:
    talker, listener = connected(zros_node)
    latched = QoS(3, durability=zros.Durability.TRANSIENT_LOCAL)
    witness = zros_node('witness').create_subscription(String, 'latched', qos=100)
    # a transient-local publisher cannot tell who matches it: a volatile one on the same topic
    # shows the witness is known to the talker's session before anything is written
    assert talker.create_publisher(String, 'latched').wait_for_subscribers(30)
    pub = talker.create_publisher(String, 'latched', qos=latched)
    for i in range(5):
        pub.write(text(str(i)))
    # once the witness has them, nothing is in flight: a late subscriber gets only history
    assert wait_for(lambda: witness.received == 5, 30)
    sub = listener.create_subscription(String, 'latched', qos=latched)
    assert wait_for(lambda: sub.received >= 3, 30)
    assert [m.data for m in sub.take()] == ['2', '3', '4']
    pub.write(text('live'))
    assert wait_for(lambda: sub.received >= 4, 30)
    # nothing more comes: each history message exactly once, then the live one
    assert not wait_for(lambda: sub.received > 4, timeout=0.3)
    assert [m.data for m in sub.take()] == ['live']


def test_timers_and_rates(zros_node: Callable[..., Node]) -> None:
    node = zros_node('clock')
    ticks: list[float] = []
    timer = node.create_timer(0.02, lambda: ticks.append(time.monotonic()))
    node.spin(timeout=0.25)
    assert 8 <= len(ticks) <= 14
    timer.cancel()
    count = len(ticks)
    node.spin(timeout=0.1)
    assert len(ticks) == count
    rate = node.create_rate(50)
    start = time.monotonic()
    for _ in range(10):
        rate.sleep()
    assert 0.15 <= time.monotonic() - start < 0.5
    with pytest.raises(ValueError, match='period must be positive'):
        node.create_timer(0, lambda: None)


def test_asyncio_iteration_and_spin(zros_node: Callable[..., Node]) -> None:
    talker, listener = connected(zros_node)
    sub = listener.create_subscription(String, 'chatter')
    got: list[str] = []
    listener.create_subscription(String, 'chatter', lambda m: got.append(m.data))
    pub = talker.create_publisher(String, 'chatter')

    async def main() -> list[str]:
        spinner = asyncio.ensure_future(listener.spin_async())
        received: list[str] = []
        assert await asyncio.to_thread(pub.wait_for_subscribers)

        async def produce() -> None:
            for i in range(5):
                pub.write(text(str(i)))
                await asyncio.sleep(0.01)

        producer = asyncio.ensure_future(produce())
        async for message in sub:
            received.append(message.data)
            if len(received) == 5:
                break
        await producer
        for _ in range(200):
            if len(got) == 5:
                break
            await asyncio.sleep(0.01)
        listener.destroy()
        await asyncio.wait_for(spinner, 1.0)
        return received

    assert asyncio.run(main()) == ['0', '1', '2', '3', '4']
    assert got == ['0', '1', '2', '3', '4']


def test_destroyed_nodes_refuse_new_entities(zros_node: Callable[..., Node]) -> None:
    node = zros_node('gone')
    sub = node.create_subscription(String, 'x')
    node.destroy()
    assert sub.closed and not node.ok()
    with pytest.raises(RuntimeError, match='was destroyed'):
        node.create_publisher(String, 'x')
    node.destroy()  # twice is fine


@pytest.mark.parametrize('qos', [10, LATCHED], ids=['volatile', 'transient_local'])
def test_closing_a_publisher_while_another_thread_writes(
    zros_node: Callable[..., Node], qos: int | QoS
) -> None:
    """close() waits for a write in progress instead of failing on it (zenoh-python refuses to
    undeclare a publisher while another thread is inside its put); writes after it raise
    zenoh.ZError, as they do when nothing races."""
    node = zros_node('talker')
    message = text('x' * 100)
    for _ in range(20):
        pub = node.create_publisher(String, 'race', qos)
        _, errors = close_while_used(pub, partial(pub.write, message))
        assert len(errors) == 1 and isinstance(errors[0], zenoh.ZError), errors


def test_writes_after_close_raise_naming_the_topic(zros_node: Callable[..., Node]) -> None:
    pub = zros_node('talker').create_publisher(String, 'closing')
    pub.close()
    with pytest.raises(zenoh.ZError, match='the publisher on /closing is closed'):
        pub.write(text('late'))
    with pytest.raises(zenoh.ZError, match='is closed'):
        pub.write_raw(b'\x00\x01\x00\x00')


class _Busy:
    """A Zenoh object another thread is inside for its first ``busy`` undeclares."""

    def __init__(self, busy: int, error: Exception | None = None) -> None:
        self.busy, self.error, self.calls = busy, error, 0

    def undeclare(self) -> None:
        self.calls += 1
        if self.error is not None:
            raise self.error
        if self.calls <= self.busy:
            raise RuntimeError('Already borrowed')


def test_undeclaring_waits_for_a_call_in_another_thread(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    from zros.runtime import entity

    busy = _Busy(3)
    entity._undeclare(busy, 'pub')
    assert busy.calls == 4 and 'waits' not in caplog.text
    monkeypatch.setattr(entity, 'WAIT_WARNING', 0.0)
    entity._undeclare(_Busy(2), 'a stuck pub')
    assert 'closing a stuck pub waits for a call another thread is still in' in caplog.text
    with pytest.raises(RuntimeError, match='something else'):  # not a busy object: not hidden
        entity._undeclare(_Busy(0, RuntimeError('something else')), 'pub')
    gone = _Busy(0, zenoh.ZError('session closed'))
    entity._undeclare(gone, 'pub')  # the session closed under it
    assert gone.calls == 1


def test_urgent_topics_are_express_unless_they_come_in_bursts() -> None:
    # express skips batching, so each message of a burst needs a transmission batch of its own:
    # topics that burst (a goal's feedback, log lines, parameter events) stay batched
    urgent = zros.Priority.INTERACTIVE_HIGH
    for topic, express in (
        ('/cmd_vel', True),
        ('/robot1/tf', True),
        ('/rosout', False),
        ('/robot1/parameter_events', False),
        ('/fibonacci/_action/feedback', False),
        ('/fibonacci/_action/status', False),
    ):
        assert QoS(10).priority_for(topic, 'std_msgs/msg/String') == (urgent, express), topic
    assert QoS(10, express=True).priority_for('/rosout', 'rcl_interfaces/msg/Log') == (urgent, True)
    assert QoS(10).priority_for('/chatter', 'std_msgs/msg/String') == (zros.Priority.DATA, False)


def test_qos_extensions_take_names_numbers_or_members_and_refuse_others() -> None:
    qos = QoS(1, congestion='block_first', priority='data_low', express=True, lifespan=0.5)
    assert qos.congestion is zros.Congestion.BLOCK_FIRST and qos.priority is zros.Priority.DATA_LOW
    assert QoS(priority=2).priority is zros.Priority.INTERACTIVE_HIGH
    assert str(qos) == (
        'reliable, volatile, keep last 1, lifespan 0.5 s, block_first, priority data_low, express'
    )
    with pytest.raises(ValueError, match='unknown priority 9; one of: real_time'):
        QoS(priority=9)
    with pytest.raises(ValueError, match="unknown congestion 'fast'; one of: drop, block"):
        QoS(congestion='fast')
    with pytest.raises(ValueError, match='lifespan is a number of seconds > 0, got 0'):
        QoS(lifespan=0)


def test_congestion_control_is_rmw_zenohs() -> None:
    drop, block = zros.Congestion.DROP, zros.Congestion.BLOCK
    for qos, expected in (
        (QoS(5, zros.Reliability.BEST_EFFORT), drop),
        (QoS(1), drop),
        (LATCHED, drop),
        (QoS(history=zros.History.KEEP_ALL), block),
        (QoS(history=zros.History.KEEP_ALL, congestion='block_first'), zros.Congestion.BLOCK_FIRST),
    ):
        assert qos.congestion_control is expected


def test_a_burst_of_small_reliable_messages_arrives_whole(zros_node: Callable[..., Node]) -> None:
    talker, listener = connected(zros_node)
    sub = listener.create_subscription(String, 'chatter', qos=QoS(3000))
    pub = talker.create_publisher(String, 'chatter')
    assert pub.wait_for_subscribers()
    for i in range(3000):
        pub.write(text(str(i)))
    assert wait_for(lambda: sub.received == 3000), f'{sub.received} of 3000 arrived'
    assert [m.data for m in sub.take()] == [str(i) for i in range(3000)]


def test_messages_past_their_lifespan_are_dropped_on_arrival_counted_and_logged(
    zros_node: Callable[..., Node],
    zros_transport: Callable[..., Transport],
    caplog: pytest.LogCaptureFixture,
) -> None:
    listener = zros_node('listener')
    sub = listener.create_subscription(String, 'chatter', qos=QoS(10, lifespan=1.0))
    sender = zros_transport()
    publisher = sender.session.declare_publisher(sub.key)
    assert wait_for(lambda: publisher.matching_status.matching)
    stamp_id = zenoh.TimestampId(bytes(sender.session.zid()))

    def put(value: str, age: float) -> None:
        stamp = zenoh.Timestamp(datetime.fromtimestamp(time.time() - age, timezone.utc), stamp_id)
        publisher.put(zros.cdr.encode(text(value)), timestamp=stamp, **put_options(listener))

    with caplog.at_level(logging.WARNING, logger='zros'):
        put('stale', 5.0)
        put('fresh', 0.0)
        put('older than a second', 1.5)
        assert wait_for(lambda: sub.received + sub.expired == 3)
    assert [m.data for m in sub.take()] == ['fresh']
    assert sub.expired == 2 and sub.dropped == 2
    warnings = [r.getMessage() for r in caplog.records if 'past its lifespan' in r.getMessage()]
    assert len(warnings) == 1 and 'arrived 5.0' in warnings[0] and 'lifespan of 1 s' in warnings[0]


def test_an_unannounced_raw_tap_hears_its_key_and_shows_nowhere(
    zros_node: Callable[..., Node],
) -> None:
    """``RawTap(announce=False)`` (zros topic hz on a type it cannot decode) subscribes through
    the one raw subscription, with the wire's admission rule, and declares no token."""
    from zros.pubsub.taps import RawTap

    talker, listener = connected(zros_node)
    publisher = talker.create_publisher('std_msgs/msg/String', '/quiet', 10)
    wire = listener.context.wire
    key = wire.any_type_key(wire.key('/quiet'))
    heard: list[zenoh.Sample] = []
    with pytest.raises(TypeError, match='an unannounced RawTap needs the key'):
        RawTap(listener, '/quiet', 'std_msgs/msg/String', qos=QoS(), key=None,
               announce=False, callback=heard.append)  # fmt: skip
    tap = RawTap(listener, '/quiet', 'std_msgs/msg/String', qos=QoS(), key=key,
                 announce=False, callback=heard.append)  # fmt: skip
    try:
        assert publisher.wait_for_subscribers(10)  # Zenoh's matching: no token needed
        publisher.write(text('hi'))
        assert wait_for(lambda: bool(heard), timeout=10)
        assert bytes(heard[0].payload.to_bytes()).endswith(b'hi\x00')
        assert listener.graph.subscribers(listener.scheme.key('/quiet')) == []
    finally:
        tap.close()


def test_destroyed_subscriptions_of_a_never_spun_node_are_released(
    zros_node: Callable[..., Node],
) -> None:
    """A program that polls (never spins) and re-subscribes on a busy topic: each destroyed
    subscription, with the messages it had queued, is freed at once, and the node's pending
    work does not grow with the subscriptions it ever had."""
    talker, listener = connected(zros_node)
    pub = talker.create_publisher(String, '/chatter')

    def churn_once() -> weakref.ref[object]:
        sub = listener.create_subscription(String, '/chatter', lambda m: None, 10)
        assert pub.wait_for_subscribers()
        assert wait_for(lambda: pub.write(text('busy')) is None and sub.received > 0)
        assert listener.destroy_subscription(sub)
        return weakref.ref(sub)

    freed = [churn_once() for _ in range(30)]
    # Zenoh drops its handle of the last one on its own thread: a moment later
    assert wait_for(lambda: gc.collect() >= 0 and all(ref() is None for ref in freed))
    assert len(listener.context.executor._ready) == 0
