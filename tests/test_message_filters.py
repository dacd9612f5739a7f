"""zros.message_filters on a loopback router: zros publishers into rclpy-named filters."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

import pytest

import zros
from zros.message_filters import (
    ApproximateTimeSynchronizer,
    Cache,
    SimpleFilter,
    Subscriber,
    TimeSynchronizer,
)
from zros.node import Node
from zros.testing import wait_for

POINT = 'geometry_msgs/msg/PointStamped'
FLOAT = 'std_msgs/msg/Float64'


def stamped(stamp_ns: int, x: float) -> zros.cdr.Message:
    message = zros.Message(POINT)
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    message.point.x = x
    return message


def test_approximate_synchronizer_runs_its_callback_when_the_node_spins(
    zros_node: Callable[..., Node],
) -> None:
    talker, listener = zros_node('talker'), zros_node('listener')
    a = Subscriber(listener, POINT, '/a')
    b = Subscriber(listener, POINT, 'b', qos_profile=20)
    sync = ApproximateTimeSynchronizer([a, b], queue_size=10, slop=0.05)
    got: list[tuple[float, float, str]] = []
    threads: set[str] = set()

    def on_pair(ma: zros.cdr.Message, mb: zros.cdr.Message, tag: str) -> None:
        got.append((ma.point.x, mb.point.x, tag))
        threads.add(threading.current_thread().name)

    assert sync.registerCallback(on_pair, 'first') == 0
    assert sync.register_callback(on_pair, 'second') == 1  # both spellings
    assert a.getTopic() == '/a'
    pub_a = talker.create_publisher(POINT, '/a')
    pub_b = talker.create_publisher(POINT, '/b')
    assert pub_a.wait_for_subscribers() and pub_b.wait_for_subscribers()
    second = 1_000_000_000
    pub_a.write(stamped(10 * second, 1.0))
    pub_b.write(stamped(10 * second + 30_000_000, 2.0))  # 30 ms: within the slop
    pub_a.write(stamped(20 * second, 3.0))
    pub_b.write(stamped(21 * second, 4.0))  # a second away: no partner
    assert wait_for(lambda: a.sub.received == 2 and b.sub.received == 2)
    assert got == []  # nothing ran on Zenoh's threads
    spinner = threading.current_thread().name
    assert wait_for(lambda: listener.spin_once(0.05) >= 0 and len(got) == 2)
    assert got == [(1.0, 2.0, 'first'), (1.0, 2.0, 'second')]
    assert threads == {spinner}


def test_time_synchronizer_and_cache(zros_node: Callable[..., Node]) -> None:
    talker, listener = zros_node('talker'), zros_node('listener')
    a, b = Subscriber(listener, POINT, '/a'), Subscriber(listener, POINT, '/b')
    cache = Cache(a, cache_size=2)
    seen: list[float] = []
    cache.registerCallback(lambda m: seen.append(m.point.x))
    sync = TimeSynchronizer([cache, b], 10)
    pairs: list[tuple[float, float]] = []
    sync.registerCallback(lambda ma, mb: pairs.append((ma.point.x, mb.point.x)))
    pub_a, pub_b = talker.create_publisher(POINT, '/a'), talker.create_publisher(POINT, '/b')
    assert pub_a.wait_for_subscribers() and pub_b.wait_for_subscribers()
    for stamp, x in ((100, 1.0), (200, 2.0), (300, 3.0)):
        pub_a.write(stamped(stamp, x))
    pub_b.write(stamped(200, 20.0))
    pub_b.write(stamped(250, 25.0))
    assert wait_for(lambda: listener.spin_once(0.05) >= 0 and len(seen) == 3 and pairs)
    assert wait_for(lambda: listener.spin_once(0.05) >= 0 and b.sub.received == 2)
    listener.spin_once(0)
    assert pairs == [(2.0, 20.0)]  # only the equal stamps
    assert [m.point.x for m in cache.getInterval(0, 1000)] == [2.0, 3.0]  # the newest two
    assert cache.getOldestTime() == zros.Time(200) and cache.getLatestTime() == zros.Time(300)
    assert cache.getElemAfterTime(zros.Time(201)).point.x == 3.0
    assert cache.getElemBeforeTime(299).point.x == 2.0
    assert cache.getElemBeforeTime(199) is None and cache.getElemAfterTime(301) is None
    assert cache.getLast().point.x == 3.0
    with pytest.raises(ValueError, match='starts after it ends'):
        cache.getInterval(300, 200)
    with pytest.raises(TypeError, match=r'integer nanoseconds or a zros\.Time'):
        cache.getElemAfterTime(1.5)  # type: ignore[arg-type]


def test_headerless_messages_are_dropped_with_a_warning_or_stamped_on_arrival(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    talker, listener = zros_node('talker'), zros_node('listener')
    f, a = Subscriber(listener, FLOAT, '/f'), Subscriber(listener, POINT, '/a')
    strict = ApproximateTimeSynchronizer([f, a], 10, 0.5)
    loose = ApproximateTimeSynchronizer([f, a], 10, 0.5, allow_headerless=True)
    dropped: list[object] = []
    matched: list[tuple[float, float]] = []
    strict.registerCallback(lambda mf, ma: dropped.append(mf))
    loose.registerCallback(lambda mf, ma: matched.append((mf.data, ma.point.x)))
    pub_f, pub_a = talker.create_publisher(FLOAT, '/f'), talker.create_publisher(POINT, '/a')
    assert pub_f.wait_for_subscribers() and pub_a.wait_for_subscribers()
    pub_a.write(stamped(listener.now().nanoseconds, 7.0))  # stamped now: meets /f on arrival
    assert wait_for(lambda: listener.spin_once(0.05) >= 0 and a.sub.received == 1)
    with caplog.at_level(logging.WARNING, 'zros.message_filters'):
        pub_f.write(zros.Message(FLOAT, data=1.5))
        assert wait_for(lambda: listener.spin_once(0.05) >= 0 and matched)
        pub_f.write(zros.Message(FLOAT, data=2.5))  # a second one: dropped, not warned again
        assert wait_for(lambda: listener.spin_once(0.05) >= 0 and f.sub.received == 2)
        listener.spin_once(0)
    assert matched == [(1.5, 7.0)] and dropped == []
    warning = [r.getMessage() for r in caplog.records if r.name == 'zros.message_filters']
    assert len(warning) == 1, warning
    assert 'drops every Float64' in warning[0] and 'allow_headerless' in warning[0]


def test_bad_settings() -> None:
    source = SimpleFilter()
    with pytest.raises(ValueError, match='cache_size must be at least 1'):
        Cache(source, cache_size=0)
    with pytest.raises(ValueError, match='queue_size must be at least 1'):
        TimeSynchronizer([source], 0)
    with pytest.raises(ValueError, match='slop must not be negative'):
        ApproximateTimeSynchronizer([source, SimpleFilter()], 10, -0.1)
    with pytest.raises(ValueError, match='at least one input'):
        ApproximateTimeSynchronizer([], 10, 0.1)


def test_with_immediate_callbacks_the_synchronizer_calls_back_without_spinning(
    zros_node: Callable[..., Node],
) -> None:
    talker, listener = zros_node('talker'), zros_node('listener', immediate_callbacks=True)
    a, b = Subscriber(listener, POINT, '/a'), Subscriber(listener, POINT, '/b')
    pairs: list[tuple[float, float]] = []
    TimeSynchronizer([a, b], 5).registerCallback(
        lambda ma, mb: pairs.append((ma.point.x, mb.point.x))
    )
    pub_a, pub_b = talker.create_publisher(POINT, '/a'), talker.create_publisher(POINT, '/b')
    assert pub_a.wait_for_subscribers() and pub_b.wait_for_subscribers()
    pub_a.write(stamped(5, 1.0))
    pub_b.write(stamped(5, 2.0))
    assert wait_for(lambda: pairs == [(1.0, 2.0)])  # no spin_once anywhere
