"""The newest large message of a paused stream, for a subscriber whose link dropped it
(zros.pubsub.tail); across a slow link in tests/transport/test_wan.py."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest
import zenoh

from tests.support.wan_rig import numbered_image
from zros.pubsub import tail as tails
from zros.pubsub.tail import LARGE, NEWEST, TAIL, Newest, Tail, ask, parse_question
from zros.testing import wait_for
from zros.transport import Transport

TIMEOUT = 20.0
IMAGE = 200_000


class _Tails:
    """Every message put under ``@zros/tail/``, as a stranger's session sees them."""

    def __init__(self, session: zenoh.Session) -> None:
        self.keys: list[str] = []
        self._lock = threading.Lock()
        session.declare_subscriber(TAIL + '**', self._on)

    def _on(self, sample: zenoh.Sample) -> None:
        with self._lock:
            self.keys.append(str(sample.key_expr))


def test_a_subscriber_that_has_the_newest_is_sent_nothing_again(zros_node: Any) -> None:
    camera = zros_node('camera').create_publisher('sensor_msgs/msg/Image', '/cam', qos=1)
    seen = zros_node('viewer').create_subscription('sensor_msgs/msg/Image', '/cam', qos=1)
    assert camera.wait_for_subscribers(TIMEOUT)
    stranger = zros_node('stranger').context.transport.session
    questions: list[bytes] = []
    asked = threading.Event()

    def on_question(query: zenoh.Query) -> None:
        questions.append(b'' if query.payload is None else query.payload.to_bytes())
        asked.set()

    stranger.declare_queryable(NEWEST + '**', on_question)
    sent = _Tails(stranger)
    for number in range(5):
        camera.write(numbered_image(number, IMAGE))
        assert wait_for(lambda n=number: seen.received > n, TIMEOUT)
    # the stream paused: the viewer asks, once, with what it has
    assert asked.wait(TIMEOUT)
    _, haves = parse_question(questions[0])
    assert len(haves) == 5
    # a stranger that asks gets the newest (as it would by subscribing); the camera took the
    # viewer's question first (same path), and sent nothing for it
    mine = 'a' * 32
    stranger.get(NEWEST + '**', lambda _: None, payload=ask(mine, []))
    assert wait_for(lambda: sent.keys == [TAIL + mine], TIMEOUT), sent.keys
    assert camera.resent == 1
    assert seen.received == 5 and seen.recovered == 0
    assert [int(m.header.frame_id) for m in seen.take()] == [4]
    assert sum(parse_question(q)[0] != mine for q in questions) == 1  # the viewer asked once


@pytest.mark.parametrize(
    'payload',
    [
        b'../cmd_vel',  # not a token: it would name another key
        b'A' * 32,  # upper case
        b'a' * 31,
        b'a' * 33,
        b'\xff' * 32,  # not ASCII
        ('\n'.join(['a' * 32] + ['x'] * 17)).encode(),  # too many timestamps
        ('a' * 32 + '\n' + 'x' * 65).encode(),  # a timestamp too long
        b'',
    ],
)
def test_questions_that_are_not_questions_are_ignored(payload: bytes) -> None:
    with pytest.raises(ValueError):
        parse_question(payload)


def _newest(transport: Transport, key: str) -> Newest:
    newest = Newest(transport.session, key, zenoh.Priority.DATA_LOW)
    newest.stamp(b'x' * LARGE)
    return newest


def test_a_publisher_answers_only_questions_and_at_most_so_often(
    zros_transport: Callable[..., Transport], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(tails, 'MAX_SENT', 3)
    publisher, stranger = zros_transport(), zros_transport()
    newest = _newest(publisher, 'cam')
    sent = _Tails(stranger.session)
    hostile = [b'../cmd_vel', b'', b'\xff' * 32, b'a' * 31 + b'/']
    for payload in hostile:
        stranger.session.get(NEWEST + 'cam', lambda _: None, payload=payload)
    tokens = [f'{index:032x}' for index in range(5)]
    for token in tokens:
        stranger.session.get(NEWEST + 'cam', lambda _: None, payload=ask(token, []))
    assert wait_for(lambda: newest.ignored == len(hostile) and newest.refused == 2, TIMEOUT)
    assert wait_for(lambda: newest.sent == 3, TIMEOUT)
    assert wait_for(lambda: len(sent.keys) == 3, TIMEOUT), sent.keys
    assert sorted(sent.keys) == [TAIL + token for token in tokens[:3]]  # sent from 3 threads
    newest.close()


def test_a_small_message_is_not_kept(zros_transport: Callable[..., Transport]) -> None:
    newest = Newest(zros_transport().session, 'cam', zenoh.Priority.DATA)
    assert newest.stamp(b'x' * (LARGE - 1)) is None
    assert newest.stamp(b'x' * LARGE) is not None
    newest.close()
    newest.close()  # twice is fine


def _samples(transport: Transport, count: int) -> list[zenoh.Sample]:
    """``count`` large samples with timestamps, as a publisher's would arrive."""
    got: list[zenoh.Sample] = []
    session = transport.session
    subscriber = session.declare_subscriber('live', got.append)
    for _ in range(count):
        session.put('live', b'x' * LARGE, timestamp=session.new_timestamp())
    assert wait_for(lambda: len(got) == count, TIMEOUT)
    subscriber.undeclare()  # type: ignore[no-untyped-call]  # untyped in zenoh's stub
    return got


def test_a_subscriber_takes_the_newest_unless_a_live_one_came_after_it_asked(
    zros_transport: Callable[..., Transport],
) -> None:
    transport = zros_transport()
    taken: list[zenoh.Sample] = []
    tail = Tail(transport, 'cam', taken.extend)
    first, second, third = _samples(transport, 3)
    tail.seen([first])
    assert tail.due() is not None
    tail.ask()
    assert tail.due() is None and tail.asked == 1  # asked once until the next large message
    session = transport.session
    # what it has already is not taken again; what it lacks is taken once
    session.put(TAIL + tail.token, b'x' * LARGE, timestamp=first.timestamp)
    session.put(TAIL + tail.token, b'x' * LARGE, timestamp=second.timestamp)
    session.put(TAIL + tail.token, b'x' * LARGE, timestamp=second.timestamp)
    assert wait_for(lambda: tail.recovered == 1, TIMEOUT)
    assert [str(s.timestamp) for s in taken] == [str(second.timestamp)]
    # a live message came after it asked: a newest that comes later is older than it
    tail.seen([third])
    session.put(TAIL + tail.token, b'y' * LARGE, timestamp=session.new_timestamp())
    later = Tail(transport, 'cam', lambda _: None)
    later.seen([first])
    later.ask()
    session.put(TAIL + later.token, b'x' * LARGE, timestamp=third.timestamp)
    assert wait_for(lambda: later.recovered == 1, TIMEOUT)  # the puts before it were handled
    assert tail.recovered == 1 and len(taken) == 1
    tail.close()
    later.close()


def test_a_tail_whose_session_closed_neither_asks_nor_fails(
    zros_transport: Callable[..., Transport],
) -> None:
    transport = zros_transport()
    tail = Tail(transport, 'cam', lambda _: None)
    tail.seen(_samples(transport, 1))
    newest = Newest(transport.session, 'cam', zenoh.Priority.DATA)
    assert newest.stamp(b'x' * LARGE) is not None  # it answers questions now
    assert tail.due() is not None  # it would ask
    transport.close()  # the node is being destroyed
    tail.ask()
    assert tail.asked == 0
    tail.close()
    newest.close()
