"""Taps: a raw subscription per watched topic, only while watched, with shallow latched topics
replayed to later watchers."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

import zros
from zros.gateway.common.watched_topics import Taps
from zros.pubsub.taps import RawTap, graph_topics
from zros.qos import QoS
from zros.testing import wait_for

Make = Callable[..., Any]
TIMEOUT = 10.0


def test_taps_exist_only_while_watched(zros_node: Make) -> None:
    talker, watcher = zros_node('talker'), zros_node('watcher')
    pub = talker.create_publisher('std_msgs/msg/String', '/chatter')
    assert watcher.graph.wait_until(lambda: '/chatter' in graph_topics(watcher), TIMEOUT)
    topic = graph_topics(watcher)['/chatter']
    taps = Taps(watcher, now=lambda: 42)
    got: list[tuple[bytes, int]] = []
    try:
        assert taps.watch(topic, 'a', lambda data, stamp: got.append((data, stamp))) == []
        assert taps.watch(topic, 'b', lambda data, stamp: None) == []  # not latched: nothing kept
        assert taps.watched() == {'/chatter': 2}
        assert pub.wait_for_subscribers(TIMEOUT)
        message = zros.Message('std_msgs/msg/String', data='tapped')
        pub.write(message)
        assert wait_for(lambda: got == [(message.serialize(), 42)], TIMEOUT)
        assert taps.counts('/chatter') == (1, len(message.serialize()))
        taps.unwatch('/chatter', 'a')
        assert pub.has_subscribers  # b still watches
        taps.unwatch('/chatter', 'b')
        assert taps.watched() == {} and taps.counts('/chatter') == (0, 0)
        assert wait_for(lambda: not pub.has_subscribers, TIMEOUT)
        taps.unwatch('/chatter', 'b')  # unknown: ignored
        taps.watch(topic, 'c', got.append)
        taps.drop('/chatter')  # the topic left the graph
        assert taps.watched() == {}
    finally:
        taps.close()


def test_a_burst_through_a_tap_arrives_whole_and_in_order(zros_node: Make) -> None:
    talker, watcher = zros_node('talker'), zros_node('watcher')
    pub = talker.create_publisher('std_msgs/msg/String', '/chatter', qos=1000)
    assert watcher.graph.wait_until(lambda: '/chatter' in graph_topics(watcher), TIMEOUT)
    stamps = iter(range(10**6))
    taps = Taps(watcher, now=lambda: next(stamps))
    got: list[tuple[bytes, int]] = []
    try:
        taps.watch(graph_topics(watcher)['/chatter'], 'a', lambda *item: got.append(item))
        assert pub.wait_for_subscribers(TIMEOUT)
        sent = [zros.Message('std_msgs/msg/String', data=str(i)).serialize() for i in range(500)]
        for data in sent:
            pub.write_raw(data)
        assert wait_for(lambda: len(got) == len(sent), TIMEOUT)
        assert [data for data, _ in got] == sent
        times = [stamp for _, stamp in got]
        assert times == sorted(times)  # one stamp per delivered batch, never going back
        assert taps.counts('/chatter') == (500, sum(map(len, sent)))
    finally:
        taps.close()


def test_a_raw_tap_takes_a_callback_or_batches(zros_node: Make) -> None:
    node = zros_node('tapper')
    for given in ({}, {'callback': print, 'batches': print}):
        with pytest.raises(TypeError, match='a callback or batches'):
            RawTap(node, '/chatter', 'std_msgs/msg/String', qos=QoS(), key=None, **given)


def test_a_failing_delivery_is_logged_and_the_tap_goes_on(
    zros_node: Make, caplog: pytest.LogCaptureFixture
) -> None:
    talker, watcher = zros_node('talker'), zros_node('watcher')
    pub = talker.create_publisher('std_msgs/msg/String', '/chatter')
    assert watcher.graph.wait_until(lambda: '/chatter' in graph_topics(watcher), TIMEOUT)
    taps = Taps(watcher)
    calls: list[bytes] = []

    def deliver(data: bytes, stamp: int) -> None:
        calls.append(data)
        raise RuntimeError('the client went away')

    try:
        taps.watch(graph_topics(watcher)['/chatter'], 'a', deliver)
        assert pub.wait_for_subscribers(TIMEOUT)
        for text in ('one', 'two'):
            pub.write(zros.Message('std_msgs/msg/String', data=text))
        assert wait_for(lambda: len(calls) == 2, TIMEOUT)
        assert caplog.text.count('delivering a message of /chatter failed (logged once)') == 1
    finally:
        taps.close()


def test_only_shallow_latched_topics_are_replayed_to_later_watchers(zros_node: Make) -> None:
    """State (/tf_static, depth 1) is kept for a later watcher; history (/rosout's 1000 logs)
    is not: it would be repeated to every watcher."""
    from zros.qos import LATCHED, ROSOUT

    talker, watcher = zros_node('talker'), zros_node('watcher')
    static = talker.create_publisher('std_msgs/msg/String', '/state', LATCHED)
    history = talker.create_publisher('std_msgs/msg/String', '/history', ROSOUT)
    message = zros.Message('std_msgs/msg/String', data='latched')
    static.write(message)
    history.write(message)

    def both() -> bool:
        topics = graph_topics(watcher)
        return {'/state', '/history'} <= set(topics) and all(
            topics[name].offered for name in ('/state', '/history')
        )

    assert watcher.graph.wait_until(both, TIMEOUT)
    taps = Taps(watcher, now=lambda: 7)
    got: dict[str, list[bytes]] = {'/state': [], '/history': []}
    try:
        for name in got:
            topic = graph_topics(watcher)[name]
            assert taps.watch(topic, 'first', lambda data, _, n=name: got[n].append(data)) == []
        assert wait_for(lambda: all(got.values()), TIMEOUT)  # both arrive to the first watcher
        state, history_topic = (graph_topics(watcher)[name] for name in got)
        assert taps.watch(state, 'second', print) == [(message.serialize(), 7)]
        assert taps.watch(history_topic, 'second', print) == []
    finally:
        taps.close()
