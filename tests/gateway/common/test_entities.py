"""Starting a gateway on its node: a node of its own is destroyed again when the start fails."""

from __future__ import annotations

import pytest

from zros.gateway.common import entities
from zros.gateway.common.errors import GatewayError


class _Node:
    def __init__(self) -> None:
        self.destroyed = False

    def destroy(self) -> None:
        self.destroyed = True


def _fails(node: object, own: bool) -> object:
    raise GatewayError('cannot start')


def test_a_node_of_its_own_goes_when_the_gateway_does_not_start(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    made: list[_Node] = []

    def gateway_node(name: str, settings: object) -> _Node:
        made.append(_Node())
        return made[-1]

    monkeypatch.setattr(entities, 'gateway_node', gateway_node)
    with pytest.raises(GatewayError, match='cannot start'):
        entities.start_gateway(None, 'g', {}, _fails)
    assert [n.destroyed for n in made] == [True]
    started: tuple[object, bool] = entities.start_gateway(None, 'g', {}, lambda n, own: (n, own))
    assert started == (made[1], True) and not made[1].destroyed


def test_a_node_given_stays_when_the_gateway_does_not_start() -> None:
    given = _Node()
    with pytest.raises(GatewayError):
        entities.start_gateway(given, 'g', {}, _fails)  # type: ignore[arg-type]
    assert not given.destroyed
    assert entities.start_gateway(given, 'g', {}, lambda node, own: own) is False  # type: ignore[arg-type]


class _Client:
    def __init__(self, key: str) -> None:
        self.key = key
        self.closed = False

    def close(self) -> None:
        self.closed = True


def test_a_cache_makes_a_client_once_per_key_and_closes_them_all() -> None:
    from zros.gateway.common.entities import ClientCache

    cache: ClientCache[_Client] = ClientCache()
    made = [cache.get(key, lambda k=key: _Client(k)) for key in ('a', 'b', 'a')]
    assert made[0] is made[2] and made[0] is not made[1]
    cache.close()
    assert made[0].closed and made[1].closed


def test_a_cache_with_a_capacity_closes_the_least_recently_used() -> None:
    # the nodes a web client asks parameters of are names it may make up: each would leave
    # a parameter client behind
    from zros.gateway.common.entities import ClientCache

    cache: ClientCache[_Client] = ClientCache(capacity=2)
    a = cache.get('a', lambda: _Client('a'))
    b = cache.get('b', lambda: _Client('b'))
    assert cache.get('a', lambda: _Client('again')) is a  # used again: b is the oldest now
    c = cache.get('c', lambda: _Client('c'))
    assert (a.closed, b.closed, c.closed) == (False, True, False)
    assert cache.get('b', lambda: _Client('b2')).key == 'b2'  # made anew; a goes
    assert a.closed


def test_a_cache_keeps_a_client_made_elsewhere_only_for_a_free_key() -> None:
    from zros.gateway.common.entities import ClientCache

    cache: ClientCache[_Client] = ClientCache()
    first, second = _Client('first'), _Client('second')
    assert cache.keep('k', first)
    assert not cache.keep('k', second)  # the caller still owns it
    assert cache.get('k', lambda: _Client('made')) is first
