"""Nodes survive their router restarting: a warning, no exception, traffic resumes."""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator

import pytest

import zros
from tests.support.router_process import RouterProcess, router_running
from zros.graph import graph_of
from zros.testing import wait_for
from zros.transport import Transport, TransportConfig


@pytest.fixture
def router_process() -> Iterator[RouterProcess]:
    with router_running() as router:
        yield router


def test_traffic_resumes_after_the_router_restarts(
    router_process: RouterProcess, caplog: pytest.LogCaptureFixture
) -> None:
    transports = [
        Transport(TransportConfig.create(connect=router_process.endpoint, shared_memory=False))
        for _ in range(2)
    ]
    try:
        talker = zros.Node('talker', transport=transports[0])
        listener = zros.Node('listener', transport=transports[1])
        sub = listener.create_subscription('std_msgs/msg/UInt64', 'count', qos=1000)
        pub = talker.create_publisher('std_msgs/msg/UInt64', 'count')
        assert pub.wait_for_subscribers()
        arrivals: list[tuple[float, int]] = []
        message = zros.Message('std_msgs/msg/UInt64')
        rate = zros.Rate(100)
        with caplog.at_level(logging.WARNING, logger='zros.transport'):
            started = time.monotonic()
            killed = restarted = None
            while time.monotonic() - started < 8:
                message.data += 1
                pub.write(message)  # raises nothing while the router is gone
                now = time.monotonic()
                arrivals += [(now, m.data) for m in sub.take()]
                if killed is None and now - started > 1.5:
                    router_process.kill()
                    killed = now
                if killed is not None and restarted is None and now - killed > 0.5:
                    router_process.start()
                    restarted = now
                rate.sleep()
        assert killed is not None and restarted is not None
        before = [t for t, _ in arrivals if t <= killed]
        after = [t for t, _ in arrivals if t > restarted]
        assert before and after, 'no traffic on one side of the restart'
        gap = after[0] - before[-1]
        assert gap < 3.0, f'{gap:.2f} s without messages'
        assert talker.ok() and listener.ok()
        assert transports[0].links_lost >= 1 and transports[0].connected
        assert 'lost the link to router' in caplog.text
        assert 'is up again' in caplog.text
        # tokens were declared again: a session that joins now sees the publisher
        with Transport(TransportConfig.create(connect=router_process.endpoint)) as late:
            graph = graph_of(late)
            assert graph.wait_until(lambda: graph.publishers('count'), timeout=5)
    finally:
        for transport in transports:
            transport.close()


def test_a_publisher_without_router_does_not_block_forever(router_process: RouterProcess) -> None:
    with Transport(TransportConfig.create(connect=router_process.endpoint)) as transport:
        node = zros.Node('lonely', transport=transport)
        pub = node.create_publisher('std_msgs/msg/String', 'void')
        router_process.kill()
        assert wait_for(lambda: not transport.connected, timeout=5)
        started = time.monotonic()
        for _ in range(100):
            pub.write(zros.Message('std_msgs/msg/String', data='into the void'))
        assert time.monotonic() - started < 2
        assert node.ok()


def test_a_session_no_node_uses_loses_its_link_quietly(
    router_process: RouterProcess, caplog: pytest.LogCaptureFixture
) -> None:
    """Nodes destroyed, the router stopped (the end of a script): nobody is told of a lost link
    that no node used; while a node lives, the loss is a warning."""

    def level_of_the_loss() -> int:
        caplog.clear()
        with caplog.at_level(logging.DEBUG, logger='zros.transport'):
            router_process.kill()
            assert wait_for(lambda: 'lost the link to router' in caplog.text, timeout=10)
        [lost] = [r for r in caplog.records if 'lost the link' in r.getMessage()]
        return lost.levelno

    with Transport(TransportConfig.create(connect=router_process.endpoint)) as transport:
        zros.Node('done', transport=transport).destroy()
        assert level_of_the_loss() == logging.DEBUG
        router_process.start()
        assert wait_for(lambda: transport.connected, timeout=15)
        node = zros.Node('working', transport=transport)
        assert level_of_the_loss() == logging.WARNING
        node.destroy()
