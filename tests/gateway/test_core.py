"""The plumbing every gateway shares: name filters, bounded client outboxes, taps that exist
only while watched, and the graph views (services, parameter nodes, owners)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest

import zros
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.common.graph_watcher import GraphWatcher
from zros.gateway.common.send_queue import SendQueue
from zros.gateway.common.views import (
    endpoint_owner,
    offered_services,
    parameter_nodes,
    service_providers,
)
from zros.gateway.common.watched_topics import Taps
from zros.gateway.foxglove.calls import message_from_json
from zros.pubsub.taps import RawTap, graph_topics
from zros.qos import QoS
from zros.testing import wait_for

Make = Callable[..., Any]
TIMEOUT = 10.0


def test_regex_filters_match_whole_names() -> None:
    everything = NameFilter.regexes()
    assert everything('/anything')
    chosen = NameFilter.regexes(['/camera/.*', '/tf'], ['.*/compressed'])
    assert chosen('/camera/image') and chosen('/tf')
    assert not chosen('/tf_static')  # a whole-name match, as foxglove_bridge's whitelists
    assert not chosen('/camera/image/compressed')
    assert not chosen('/odom')
    with pytest.raises(GatewayError, match=r"'\[' is not a valid regex"):
        NameFilter.regexes(['['])


def test_glob_filters() -> None:
    chosen = NameFilter.globs(['/camera/*', '/tf'], ['*/compressed'])
    assert chosen('/camera/image') and chosen('/tf')
    assert not chosen('/camera/image/compressed') and not chosen('/tf_static')
    assert 'include' in repr(chosen)


def test_a_send_queue_drops_its_oldest_items_and_tells_once_per_burst() -> None:
    reports: list[int] = []
    outbox: SendQueue[str] = SendQueue(max_items=4, max_bytes=100, on_drop=reports.append)
    for i in range(6):
        outbox.put(f'm{i}', 10)
    assert len(outbox) == 4 and outbox.dropped == 2
    assert reports == [1]  # told at the start of the burst, not per item
    assert [outbox.get(0) for _ in range(4)] == ['m2', 'm3', 'm4', 'm5']
    outbox.put('small', 10)
    outbox.put('huge', 95)  # over the byte bound with 'small': the oldest goes
    assert outbox.dropped == 3 and reports == [1, 3]
    assert outbox.size == 95
    assert outbox.get(0) == 'huge'
    assert outbox.get(0.01) is None


def test_a_send_queue_wakes_a_waiting_reader_and_closes() -> None:
    outbox: SendQueue[int] = SendQueue()
    got: list[int | None] = []
    reader = threading.Thread(target=lambda: got.append(outbox.get(TIMEOUT)))
    reader.start()
    outbox.put(7, 1)
    reader.join(TIMEOUT)
    assert got == [7]
    closing = threading.Thread(target=lambda: got.append(outbox.get(TIMEOUT)))
    closing.start()
    outbox.close()
    closing.join(TIMEOUT)
    assert got == [7, None]
    outbox.put(8, 1)  # ignored once closed
    assert len(outbox) == 0
    with pytest.raises(ValueError, match='at least one'):
        SendQueue(max_items=0)


def test_a_failing_drop_callback_is_logged(caplog: pytest.LogCaptureFixture) -> None:
    def broken(count: int) -> None:
        raise RuntimeError('nope')

    outbox: SendQueue[int] = SendQueue(max_items=1, on_drop=broken)
    outbox.put(1, 1)
    outbox.put(2, 1)
    assert outbox.get(0) == 2
    assert 'the drop callback' in caplog.text


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


def test_a_graph_watcher_calls_back_on_changes(
    zros_node: Make, caplog: pytest.LogCaptureFixture
) -> None:
    observer = zros_node('observer')
    seen: list[int] = []

    def look() -> None:
        seen.append(len(graph_topics(observer)))
        if len(seen) == 2:
            raise RuntimeError('one bad look')

    watcher = GraphWatcher(observer, look)
    try:
        talker = zros_node('talker')
        talker.create_publisher('std_msgs/msg/String', '/one')
        assert wait_for(lambda: seen and seen[-1] >= 1, TIMEOUT)
        talker.create_publisher('std_msgs/msg/String', '/two')
        assert wait_for(lambda: seen[-1] >= 2, TIMEOUT)
        # the look that raises appended first: its error is logged a moment later
        assert wait_for(lambda: 'the gateway failed to follow the graph' in caplog.text, TIMEOUT)
    finally:
        watcher.close()


def test_graph_views(zros_node: Make) -> None:
    server = zros_node('adder', start_parameter_services=True)
    server.create_service('example_interfaces/srv/AddTwoInts', '/add_two_ints')
    server.create_service('std_srvs/srv/Empty', '/_hidden')
    observer = zros_node('observer', start_parameter_services=False)
    # the parameter services are declared after /add_two_ints's node, each in a token of its own
    assert observer.graph.wait_until(
        lambda: (
            parameter_nodes(offered_services(observer)) == ['/adder']
            and '/add_two_ints' in offered_services(observer)
        ),
        TIMEOUT,
    )
    services = offered_services(observer)
    assert services['/add_two_ints'] == 'example_interfaces/srv/AddTwoInts'
    assert '/_hidden' not in services
    assert '/_hidden' in offered_services(observer, include_hidden=True)
    # which node owns an endpoint arrives in a token of its own, just after the endpoint's
    assert observer.graph.wait_until(
        lambda: '/add_two_ints' not in offered_services(observer, exclude_node='/adder'), TIMEOUT
    )
    assert parameter_nodes(services) == ['/adder']
    assert parameter_nodes({'/x/get_parameters': 'rcl_interfaces/srv/GetParameters'}) == []
    (endpoint,) = [
        e
        for e in observer.graph.endpoints()
        if e.ros_name(observer.scheme.namespace) == '/add_two_ints'
    ]
    assert endpoint_owner(endpoint, observer.graph) == '/adder'
    assert service_providers(observer, ['/add_two_ints', '/nothing']) == {
        '/add_two_ints': ['/adder']
    }


def test_messages_from_json() -> None:
    Twist = type(zros.Message('geometry_msgs/msg/Twist'))
    twist = message_from_json(Twist, '{"linear": {"x": 1}, "angular": {"z": -2.5}}')
    assert (twist.linear.x, twist.angular.z) == (1.0, -2.5)
    for text, error in (
        ('[1, 2]', 'needs a mapping'),
        ('{"spin": 1}', "no field 'spin'"),
        ('{', 'cannot make'),
    ):
        with pytest.raises(GatewayError, match=error):
            message_from_json(Twist, text)


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
