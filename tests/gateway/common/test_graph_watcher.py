"""The graph watcher calls back on changes and outlives a failing look."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

from zros.gateway.common.graph_watcher import GraphWatcher
from zros.pubsub.taps import graph_topics
from zros.testing import wait_for

Make = Callable[..., Any]
TIMEOUT = 10.0


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
