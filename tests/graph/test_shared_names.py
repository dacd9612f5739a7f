"""Two nodes of one name: the graph counts both (as ``ros2 node list`` shows both), and a
node made under a name the session's graph already shows logs a warning (rcl refuses neither)."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from zros.graph import graph_of
from zros.testing import wait_for
from zros.wire import SCHEMES

Node = Callable[..., Any]


@pytest.fixture(params=list(SCHEMES))
def zros_wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture
def ros_warnings() -> Iterator[list[str]]:
    """The messages of the warnings node loggers write (the ``ros`` logger)."""
    captured: list[str] = []

    class Capture(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            if record.levelno >= logging.WARNING:
                captured.append(record.getMessage())

    logger = logging.getLogger('ros')
    capture = Capture()
    logger.addHandler(capture)
    try:
        yield captured
    finally:
        logger.removeHandler(capture)


def test_the_graph_counts_each_node_of_a_shared_name(zros_node: Node) -> None:
    first = zros_node('twin')
    zros_node('twin')
    zros_node('single')
    graph = graph_of(first.transport)
    graph.refresh()
    assert wait_for(lambda: graph.node_instances().count('/twin') == 2, timeout=10)
    assert graph.node_instances().count('/single') == 1
    assert graph.nodes().count('/twin') == 1  # names stay unique there


def test_a_node_named_as_one_the_graph_shows_logs_a_warning(
    zros_node: Node, ros_warnings: list[str]
) -> None:
    first = zros_node('twin')
    graph = graph_of(first.transport)  # the session follows the graph already
    zros_node('other', transport=first.transport)
    assert ros_warnings == []
    zros_node('twin', transport=first.transport)  # known at once: no wait for discovery
    assert ros_warnings == [
        'a node named /twin is already on the network; both run, but whatever reaches a '
        'node by name (parameters, node info) may reach either'
    ]
    assert graph.node_instances().count('/twin') >= 1
