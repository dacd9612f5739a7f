"""Playing bags into the graph: order, timing, rate, loops, selection, QoS and /clock."""

from __future__ import annotations

import random
import statistics
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import zros
from zros.bag import BagError
from zros.bag.errors import PlayerError
from zros.bag.play.play_clock import PlayClock
from zros.bag.play.play_topics import parse_remap, playback_qos
from zros.bag.play.player import Player
from zros.bag.write.bag_writer import BagTopic, BagWriter
from zros.bag.write.recorder import Recorder
from zros.cdr import default_registry, encode
from zros.keyexpr.kinds import EntityKind
from zros.qos import Congestion, Durability, History, QoS, Reliability
from zros.testing import wait_for

Node = Callable[..., Any]
STRING = 'std_msgs/msg/String'
START = 1_700_000_000_000_000_000
MS = 1_000_000


def write_bag(
    path: Path,
    messages: list[tuple[str, int, str]],
    qos: dict[str, list[QoS]] | None = None,
    type_name: str = STRING,
) -> Path:
    """A bag of strings: (topic, timestamp, text) each."""
    cls = default_registry().get_class(type_name)
    with BagWriter(path) as bag:
        index: dict[str, int] = {}
        for topic, stamp, text in messages:
            if topic not in index:
                entry = BagTopic.from_registry(
                    default_registry(), topic, type_name, (qos or {}).get(topic, [QoS(10)])
                )
                index[topic] = bag.add_topic(entry)
            bag.write(index[topic], stamp, encode(cls(data=text)))
    return path


def irregular(count: int, topics: list[str], seed: int = 1) -> list[tuple[str, int, str]]:
    """``count`` messages 2 to 20 ms apart, cycling through ``topics``."""
    rng = random.Random(seed)
    stamp = START
    found = []
    for n in range(count):
        stamp += rng.randint(2, 20) * MS
        found.append((topics[n % len(topics)], stamp, f'm{n}'))
    return found


def selector(node: Any, pattern: str) -> str:
    """The key expression of the ROS names matching ``pattern`` (``/play/*``) on the node's wire."""
    key = node.scheme.key(pattern.replace('*', 'any_chunk')).replace('any_chunk', '*')
    return key + '/*/*' if node.wire.name == 'rmw_zenoh' else key  # rmw_zenoh: type and hash follow


def topic_key(node: Any, key: str) -> str:
    """A sample's key without rmw_zenoh's domain, type and hash chunks."""
    return '/'.join(key.split('/')[1:-2]) if node.wire.name == 'rmw_zenoh' else key


class Listener:
    """A raw Zenoh subscriber on some topics: (monotonic ns, topic key, text) of every sample."""

    def __init__(self, node: Any, pattern: str) -> None:
        self.node = node
        self.got: list[tuple[int, str, str]] = []
        cls = default_registry().get_class(STRING)
        self._decode = lambda data: zros.cdr.decode(cls, data).data
        self._subscriber = node.transport.session.declare_subscriber(
            selector(node, pattern), self._on_sample
        )

    def _on_sample(self, sample: Any) -> None:
        self.got.append(
            (
                time.monotonic_ns(),
                topic_key(self.node, str(sample.key_expr)),
                self._decode(sample.payload.to_bytes()),
            )
        )

    def texts(self) -> list[str]:
        return [text for _, _, text in self.got]


@pytest.fixture
def player_node(zros_node: Node) -> Iterator[Any]:
    yield zros_node('player')


def gap_errors_ms(
    listener: Listener, messages: list[tuple[str, int, str]], rate: float
) -> list[float]:
    received = [stamp for stamp, _, _ in listener.got]
    sent = [stamp for _, stamp, _ in messages]
    return [
        abs((received[i + 1] - received[i]) - (sent[i + 1] - sent[i]) / rate) / MS
        for i in range(len(sent) - 1)
    ]


# --- timing ------------------------------------------------------------------------------------


@pytest.mark.parametrize('rate', [1.0, 2.0])
def test_order_and_timing(zros_node: Node, player_node: Any, tmp_path: Path, rate: float) -> None:
    messages = irregular(150, ['/play/a', '/play/b'])
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/play/*')
    with Player(player_node, bag, rate=rate, wait_for_subscribers=5.0) as player:
        player.play()
        assert player.published == 150
    assert wait_for(lambda: len(listener.got) == 150)
    assert listener.texts() == [text for _, _, text in messages]
    assert [key for _, key, _ in listener.got] == [t[1:] for t, _, _ in messages]
    errors = gap_errors_ms(listener, messages, rate)
    assert statistics.median(errors) < 5.0, sorted(errors)[-10:]
    # no drift: each arrival's lag behind its due time is the same at the end as at the start.
    # A loaded machine only ever delays arrivals (a player on time catches up after a stall),
    # so the least lag of the first and of the last 30 messages is what the player kept
    lags = [
        (got[0] - listener.got[0][0]) / MS - (sent[1] - messages[0][1]) / MS / rate
        for got, sent in zip(listener.got, messages, strict=True)
    ]
    drift = min(lags[-30:]) - min(lags[:30])
    assert abs(drift) < 50, (drift, sorted(lags)[:3], sorted(lags)[-3:])


def test_start_offset_skips_the_beginning(
    zros_node: Node, player_node: Any, tmp_path: Path
) -> None:
    messages = [('/off', START + n * 100 * MS, str(n)) for n in range(10)]
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/off')
    with Player(player_node, bag, start_offset=0.45, wait_for_subscribers=5.0) as player:
        began = time.monotonic_ns()
        player.play()
    assert wait_for(lambda: len(listener.got) == 5)
    assert listener.texts() == ['5', '6', '7', '8', '9']
    # the first one played is due 50 ms after the offset, not at once
    assert 30 * MS < listener.got[0][0] - began < 500 * MS


def test_loop_plays_again_and_again(zros_node: Node, player_node: Any, tmp_path: Path) -> None:
    messages = [('/again', START + n * 5 * MS, str(n)) for n in range(5)]
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/again')
    player = Player(player_node, bag, loop=True, wait_for_subscribers=5.0)
    player.start()
    assert wait_for(lambda: len(listener.got) >= 16, 10)
    player.close()
    assert player.loops >= 3
    texts = listener.texts()
    assert texts[:15] == ['0', '1', '2', '3', '4'] * 3


def test_topic_selection_and_remap(zros_node: Node, player_node: Any, tmp_path: Path) -> None:
    messages = []
    for n in range(6):
        for topic in ('/sel/a', '/sel/b', '/sel/c'):
            messages.append((topic, START + (3 * n + len(messages) % 3) * MS, f'{topic}{n}'))
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/sel/*')
    with Player(
        player_node, bag, topics=['sel/a', '/sel/b'], remap=['sel/a:=/sel/x'],
        wait_for_subscribers=5.0,
    ) as player:  # fmt: skip
        assert player.topics == {'/sel/x': STRING, '/sel/b': STRING}
        player.play()
    assert wait_for(lambda: len(listener.got) == 12)
    keys = {key for _, key, _ in listener.got}
    assert keys == {'sel/x', 'sel/b'}  # nothing on /sel/a or /sel/c, which came in between
    got_x = [text for _, key, text in listener.got if key == 'sel/x']
    assert got_x == [f'/sel/a{n}' for n in range(6)]


# --- QoS and /clock ----------------------------------------------------------------------------


def test_latched_topics_stay_latched(zros_node: Node, player_node: Any, tmp_path: Path) -> None:
    latched = QoS(1, durability=Durability.TRANSIENT_LOCAL)
    bag = write_bag(
        tmp_path / 'bag',
        [('/static', START, 'once'), ('/plain', START + MS, 'p')],
        {'/static': [latched]},
    )
    with Player(player_node, bag) as player:
        player.play()
        late = zros_node('late')
        subscriber = late.create_subscription(STRING, '/static', qos='latched')
        message = subscriber.wait_for_message(timeout=5)
        assert message is not None and message.data == 'once'

        def announced() -> list[Any]:
            return [
                e
                for e in late.graph.endpoints((EntityKind.PUBLISHER,))
                if e.ros_name(late.scheme.namespace) == '/static'
            ]

        assert late.graph.wait_until(announced, 5)
        (publisher,) = announced()
        assert publisher.qos is not None and publisher.qos.transient_local


def test_a_fast_burst_on_an_urgent_topic_arrives_whole(
    zros_node: Node, zros_transport: Callable[..., Any], tmp_path: Path
) -> None:
    # /tf's messages are express (each a Zenoh batch of its own, 2 queued per priority): under
    # congestion control DROP, whatever the link's thread had not sent within 1 ms was dropped
    # (tf_nav2 at -r 10 lost 5 to 300 of 5,422 on a loaded machine). That wait is 0 here, so
    # that the loss does not depend on the machine's load.
    impatient = zros_transport(
        zenoh={'transport/link/tx/queue/congestion_control/drop/wait_before_drop': 0}
    )
    player_node = zros_node('player', transport=impatient)
    messages = [
        ('/burst/tf', START + burst * 10 * MS, f'{burst}.{n}')
        for burst in range(5)
        for n in range(600)
    ]
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/burst/*')
    with Player(player_node, bag, rate=10, wait_for_subscribers=5.0) as player:
        (publisher,) = set(player._publishers.values())
        assert publisher.express  # the case that lost messages
        player.play()
        assert player.published == 3000
        assert wait_for(lambda: len(listener.got) == 3000, 20), f'{3000 - len(listener.got)} lost'
    assert listener.texts() == [text for _, _, text in messages]


def test_playback_qos_follows_the_offers() -> None:
    latched = QoS(1, durability=Durability.TRANSIENT_LOCAL)
    block = Congestion.BLOCK  # reliable publishers wait for room rather than drop
    assert playback_qos([latched, latched]) == latched.with_(congestion=block)
    assert playback_qos([latched, QoS(5)]) == QoS(5, congestion=block)
    assert playback_qos([QoS(3, Reliability.BEST_EFFORT)]) == QoS(3, Reliability.BEST_EFFORT)
    assert playback_qos([QoS(7, history=History.KEEP_ALL)]).keep_all
    assert playback_qos([]) == QoS(10, congestion=block)


def test_clock_drives_a_sim_time_node(zros_node: Node, player_node: Any, tmp_path: Path) -> None:
    base = 1_000 * 10**9  # a simulation's time, far from the wall clock
    messages = [('/sim', base + n * 20 * MS, str(n)) for n in range(1, 26)]
    bag = write_bag(tmp_path / 'bag', messages)
    sim = zros_node('sim', use_sim_time=True)
    assert sim.now().nanoseconds == 0
    seen: list[tuple[int, int]] = []  # (sim time at arrival, bag time of the message)
    lock = threading.Lock()

    def on_sample(sample: Any) -> None:
        text = zros.cdr.decode(default_registry().get_class(STRING), sample.payload.to_bytes())
        with lock:
            seen.append((sim.now().nanoseconds, messages[int(text.data) - 1][1]))

    subscription = sim.transport.session.declare_subscriber(selector(sim, '/sim'), on_sample)
    try:
        with Player(player_node, bag, clock=200, wait_for_subscribers=5.0) as player:
            player.play()
        assert wait_for(lambda: len(seen) == 25)
        assert wait_for(lambda: sim.now().nanoseconds >= messages[-1][1])
        assert sim.now().nanoseconds < messages[-1][1] + 200 * MS
        for now, stamp in seen:  # within a /clock period (5 ms) and the delivery delay
            assert abs(now - stamp) < 30 * MS, (now - stamp) / MS
    finally:
        subscription.undeclare()


# --- steering ----------------------------------------------------------------------------------


def test_pause_step_resume(zros_node: Node, player_node: Any, tmp_path: Path) -> None:
    messages = [('/steps', START + n * 10 * MS, str(n)) for n in range(6)]
    bag = write_bag(tmp_path / 'bag', messages)
    listener = Listener(zros_node('listener'), '/steps')
    player = Player(player_node, bag, wait_for_subscribers=5.0)
    player.start(paused=True)
    assert player.paused
    assert not wait_for(lambda: player.published, 0.2)  # nothing moves while paused
    player.step()
    assert wait_for(lambda: player.published == 1)
    player.step()
    assert wait_for(lambda: player.published == 2)
    assert player.clock.now() == messages[1][1]  # bag time jumped to the stepped message
    assert not wait_for(lambda: player.published > 2, 0.1)
    player.resume()
    assert player.wait(5)
    assert wait_for(lambda: len(listener.got) == 6)
    assert listener.texts() == [str(n) for n in range(6)]
    player.close()


def test_play_clock() -> None:
    clock = PlayClock(1_000, rate=2.0)
    before = clock.now()
    assert wait_for(lambda: clock.now() >= before + 10 * MS)  # twice the wall clock's pace
    clock.pause()
    frozen = clock.now()
    assert clock.now() == frozen and clock.paused
    assert not clock.sleep_until(frozen + 1, stopped=lambda: True)
    clock.jump(5 * 10**9)
    assert clock.now() == 5 * 10**9
    clock.resume()
    clock.set_rate(1000.0)
    assert clock.sleep_until(clock.now() + 10**9)  # 1 s of bag time in 1 ms
    with pytest.raises(ValueError, match='positive'):
        clock.set_rate(0)
    with pytest.raises(ValueError, match='positive'):
        PlayClock(0, rate=-1)


def test_play_into_a_recorder_gives_the_same_bag(
    zros_node: Node, player_node: Any, tmp_path: Path
) -> None:
    messages = irregular(60, ['/trip/a', '/trip/b'], seed=7)
    bag = write_bag(tmp_path / 'original', messages)
    recorder = Recorder(zros_node('recording'), tmp_path / 'copy', regex='^/trip/')
    with Player(player_node, bag) as player:
        assert recorder.wait_for_topics(['/trip/a', '/trip/b'])
        assert player.wait_for_subscribers(5)
        player.play()
    assert wait_for(lambda: recorder.message_count == 60)
    recorder.close()
    from zros.bag import open_source

    with open_source(tmp_path / 'original') as first, open_source(tmp_path / 'copy') as second:
        original = list(first.messages())
        copy = list(second.messages())
    # each topic has a subscription (and a Zenoh callback thread) of its own in the recorder:
    # the order holds per topic, and so do the gaps
    drift: list[float] = []
    for topic in ('/trip/a', '/trip/b'):
        mine = [m for m in copy if m.connection.topic == topic]
        theirs = [m for m in original if m.connection.topic == topic]
        assert [bytes(m.data) for m in mine] == [bytes(m.data) for m in theirs]
        drift.extend(
            abs((b.timestamp - a.timestamp) - (d.timestamp - c.timestamp)) / MS
            for a, b, c, d in zip(mine, mine[1:], theirs, theirs[1:], strict=False)
        )
    assert statistics.median(drift) < 5.0


# --- errors ------------------------------------------------------------------------------------


def test_refusals(player_node: Any, tmp_path: Path) -> None:
    bag = write_bag(tmp_path / 'bag', [('/a', START, 'x')])
    with pytest.raises(PlayerError, match='rate'):
        Player(player_node, bag, rate=0)
    with pytest.raises(PlayerError, match='offset'):
        Player(player_node, bag, start_offset=-1)
    with pytest.raises(PlayerError, match='frequency'):
        Player(player_node, bag, clock=0.0)
    with pytest.raises(PlayerError, match='no topic /nope; it has /a'):
        Player(player_node, bag, topics=['/nope'])
    with pytest.raises(PlayerError, match='/from:=/to'):
        Player(player_node, bag, remap=['/a=/b'])
    with pytest.raises(BagError):
        Player(player_node, tmp_path / 'missing')
    with pytest.raises(zros.NotInitializedError):
        Player(None, bag)
    assert parse_remap({'/a': '/b'}) == {'/a': '/b'}


def test_types_come_from_the_bag_when_the_node_does_not_know_them(
    zros_node: Node, player_node: Any, tmp_path: Path
) -> None:
    cls_text = 'int32 level\nstring note\n'
    with BagWriter(tmp_path / 'own') as bag:
        index = bag.add_topic(BagTopic('/own', 'their_pkg/msg/Level', cls_text))
        from zros.cdr import TypeRegistry

        registry = TypeRegistry()
        registry.register_text('their_pkg/msg/Level', cls_text)
        level = registry.get_class('their_pkg/msg/Level')
        bag.write(index, START, encode(level(level=4, note='hi')))
    with BagWriter(tmp_path / 'blind') as bag:
        bag.add_topic(BagTopic('/blind', 'their_pkg/msg/Secret'))
    got: list[bytes] = []
    listener = zros_node('listener')
    subscription = listener.transport.session.declare_subscriber(
        selector(listener, '/own'), lambda s: got.append(s.payload.to_bytes())
    )
    with Player(player_node, tmp_path / 'own', wait_for_subscribers=5.0) as player:
        assert player.topics == {'/own': 'their_pkg/msg/Level'}
        player.play()
    assert wait_for(lambda: got)
    assert got == [encode(level(level=4, note='hi'))]
    subscription.undeclare()
    with pytest.raises(PlayerError, match=r'no definition of their_pkg/msg/Secret.*ZROS_INTERF'):
        Player(player_node, tmp_path / 'blind')


def test_a_stop_at_any_moment_of_the_start_ends_playing(player_node: Any, tmp_path: Path) -> None:
    # a stop between the player's check and its wait for the reader's next batch once made
    # wait() block for good (the reader ended without its end marker)
    bag = write_bag(tmp_path / 'bag', [('/late', START, 'a'), ('/late', START + 3600 * 10**9, 'b')])
    delays = [n * 0.0002 for n in range(25)] * 4
    for delay in delays:
        player = Player(player_node, bag)
        player.start()
        deadline = time.perf_counter() + delay
        while time.perf_counter() < deadline:  # a precise, tiny offset into the start
            pass
        player.stop()
        assert player.wait(10), f'playing did not end after a stop {delay * 1000:.1f} ms in'
        player.close()


def test_service_events_are_skipped_with_one_warning(
    player_node: Any, testdata: Path, caplog: pytest.LogCaptureFixture
) -> None:
    bag = testdata / 'ros2' / 'services_and_topics'
    with caplog.at_level('WARNING', logger='zros'), Player(player_node, bag) as player:
        assert player.topics
        assert not any(t.endswith('/_service_event') for t in player.topics)
    warnings = [r.getMessage() for r in caplog.records if 'service events' in r.getMessage()]
    assert len(warnings) == 1 and '/_service_event' in warnings[0]
    event = '/add_two_ints/_service_event'
    with pytest.raises(PlayerError, match=f'cannot play {event}: zros does not play service'):
        Player(player_node, bag, topics=[event])


def test_an_empty_message_type_plays_from_its_empty_definition(
    player_node: Any, testdata: Path
) -> None:
    # test_msgs/msg/Empty is unknown to zros; the bag's definition of it is '' (no fields)
    with Player(player_node, testdata / 'ros2' / 'convert_b_mcap', topics=['a_empty']) as player:
        assert player.topics == {'/a_empty': 'test_msgs/msg/Empty'}
