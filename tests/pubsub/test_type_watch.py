"""A publisher or subscriber whose type differs from another endpoint's on its topic logs one
warning naming both types and the other node, and what the wire does with the two."""

from __future__ import annotations

import logging
from collections.abc import Callable

import pytest

from zros.keyexpr.kinds import EntityKind
from zros.node import Node
from zros.pubsub.type_watch import type_watch_of
from zros.testing import wait_for


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module runs on both wire schemes."""
    return str(request.param)


String, Int32 = 'std_msgs/msg/String', 'std_msgs/msg/Int32'
#: what each wire says the two endpoints do
CONSEQUENCE = {'bridge': 'fail to decode', 'rmw_zenoh': 'never match'}


def warnings_of(caplog: pytest.LogCaptureFixture, node: str) -> list[str]:
    """The type warnings written from the side of ``node``."""
    return [
        r.getMessage()
        for r in caplog.records
        if r.levelno == logging.WARNING and f' of {node} carries ' in r.getMessage()[:80]
    ]


def subscribers(node: Node, topic: str) -> int:
    namespace = node.wire.namespace
    found = node.graph.endpoints((EntityKind.SUBSCRIBER,))
    return sum(e.ros_name(namespace) == topic for e in found)


def watched_all(node: Node) -> bool:
    """Whether the type watch of ``node``'s session has looked at the graph as it is now."""
    watch = type_watch_of(node.context.transport)
    return watch.checked >= node.graph.version


def test_a_subscriber_of_another_type_warns_once_on_each_side(
    zros_node: Callable[..., Node], zros_wire: str, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger='zros')
    talker, listener = zros_node('talker'), zros_node('listener')
    talker.create_publisher(String, 'chatter')
    listener.create_subscription(Int32, 'chatter', lambda m: None)
    assert wait_for(lambda: warnings_of(caplog, '/listener') and warnings_of(caplog, '/talker'))
    [heard] = warnings_of(caplog, '/listener')
    assert heard.startswith(
        f'/chatter: the subscriber of /listener carries {Int32}, '
        f'but the publisher of /talker carries {String}: '
    )
    assert CONSEQUENCE[zros_wire] in heard
    [said] = warnings_of(caplog, '/talker')
    assert said.startswith(
        f'/chatter: the publisher of /talker carries {String}, '
        f'but the subscriber of /listener carries {Int32}: '
    )
    assert CONSEQUENCE[zros_wire] in said
    # the graph changes again (a third node comes): no more warnings
    zros_node('other').create_subscription(String, 'elsewhere', lambda m: None)
    for node in (talker, listener):
        assert wait_for(lambda n=node: subscribers(n, '/elsewhere') == 1)
        assert wait_for(lambda n=node: watched_all(n))
    assert len(warnings_of(caplog, '/listener')) == 1
    assert len(warnings_of(caplog, '/talker')) == 1


def test_an_endpoint_the_graph_shows_already_is_checked_when_made(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger='zros')
    talker = zros_node('talker')
    listener = zros_node('listener', transport=talker.context.transport)
    talker.create_subscription(String, 'chatter', lambda m: None)
    assert wait_for(lambda: subscribers(talker, '/chatter') == 1)
    listener.create_publisher(Int32, 'chatter')  # the check at creation warns before it returns
    [said] = warnings_of(caplog, '/listener')
    assert f'but the subscriber of /talker carries {String}' in said
    # one session, one warning for the pair: the subscriber's side does not repeat it
    assert wait_for(lambda: len(talker.graph.publishers(listener.wire.key('/chatter'))) == 1)
    assert wait_for(lambda: watched_all(talker))
    assert warnings_of(caplog, '/talker') == []


def test_the_same_type_and_other_topics_warn_nothing(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.WARNING, logger='zros')
    talker, listener = zros_node('talker'), zros_node('listener')
    pub = talker.create_publisher(String, 'chatter')
    listener.create_subscription(String, 'chatter', lambda m: None)
    listener.create_subscription(Int32, 'count', lambda m: None)
    assert pub.wait_for_subscribers()
    for node in (talker, listener):
        assert wait_for(lambda n=node: subscribers(n, '/count') == 1)
        assert wait_for(lambda n=node: watched_all(n))
    assert [r for r in caplog.records if r.levelno >= logging.WARNING] == []
