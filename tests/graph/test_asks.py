"""The graph learns the tokens present by asking (its subscribers hear news only), and an
answer that crossed a token's undeclaration does not bring the token back."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from zenoh import SampleKind

from zros.graph import Graph
from zros.keyexpr.owners import node_token
from zros.testing import wait_for
from zros.wire.tokens import LocalToken

Node = Callable[..., Any]
MakeTransport = Callable[..., Any]


def test_a_new_graph_shows_the_nodes_already_there_without_a_refresh(
    zros_node: Node, zros_transport: MakeTransport
) -> None:
    zros_node('already')
    graph = Graph(zros_transport())
    try:
        assert wait_for(lambda: '/already' in graph.nodes(), timeout=10)
    finally:
        graph.close()


def test_an_answer_that_crossed_an_undeclaration_does_not_revive_the_node(
    zros_transport: MakeTransport,
) -> None:
    graph = Graph(zros_transport())
    try:
        key = node_token('0123456789abcdef0123456789abcdef', '/ghost')
        matching = [handler for selector, handler in graph._matchers if selector.intersects(key)]
        assert matching
        heard = [graph._heard(handler) for handler in matching]
        for hear in heard:
            hear(LocalToken(key, SampleKind.PUT))
        assert '/ghost' in graph.nodes()
        graph._asking += 1  # an ask is on its way: its answer still holds the token
        for hear in heard:
            hear(LocalToken(key, SampleKind.DELETE))  # the node left meanwhile
        for handler in matching:
            graph._unless_gone(handler, LocalToken(key, SampleKind.PUT))  # the stale answer
        assert '/ghost' not in graph.nodes()
    finally:
        graph.close()
