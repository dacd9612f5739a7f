"""A warning when a topic's publishers and subscribers disagree on its type.

Each session's :class:`TypeWatch` knows its open publishers and subscribers. It compares each
with the endpoints the graph shows on the same topic and wire, once when the entity is made and
then on a thread of its own each time the graph changes (a burst of changes costs one look), and
logs one warning per pair of disagreeing endpoints, naming both types and the other node, and
what the wire does with them. Nothing of it runs per message.
"""

from __future__ import annotations

import functools
import logging
import threading
from dataclasses import dataclass

from zros.graph import Graph, graph_of
from zros.keyexpr.kinds import EntityKind
from zros.runtime.entity import Entity
from zros.transport.per_session import PerSession
from zros.transport.session import Transport
from zros.wire import Endpoint

_log = logging.getLogger('zros')

_KINDS = (EntityKind.PUBLISHER, EntityKind.SUBSCRIBER)
_WORDS = {EntityKind.PUBLISHER: 'publisher', EntityKind.SUBSCRIBER: 'subscriber'}


@dataclass(frozen=True)
class _Watched:
    """What the watch knows of one of the session's publishers or subscribers."""

    kind: EntityKind
    topic: str
    type_name: str
    node: str
    wire: str  #: its scheme's name
    key: str  #: how the graph identifies its topic on that scheme
    conflict: str  #: what a type conflict does on that scheme


class TypeWatch:
    """The publishers and subscribers of one session, checked against the graph's."""

    def __init__(self, transport: Transport) -> None:
        self._graph = graph_of(transport)
        self._lock = threading.Lock()
        self._watched: dict[int, _Watched] = {}  #: by the entity's id()
        #: the disagreements warned of: (wire, key, {(node, type), (other node, other type)})
        self._warned: set[tuple[str, str, frozenset[tuple[str, str]]]] = set()
        self._thread: threading.Thread | None = None
        self.checked = -1  #: the graph's version its thread checked last

    def watch(self, entity: Entity, kind: EntityKind, topic: str, type_name: str) -> None:
        """Check ``entity`` (a publisher or subscriber of ``kind`` on ``topic``) now and on
        every change of the graph until :meth:`forget`."""
        wire = entity.context.wire
        watched = _Watched(
            kind, topic, type_name, wire.node_fqn, wire.name, wire.key(topic),
            type(wire).type_conflict,
        )  # fmt: skip
        with self._lock:
            self._watched[id(entity)] = watched
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._follow, name='zros type watch', daemon=True
                )
                self._thread.start()
        self._check([watched])

    def forget(self, entity: object) -> None:
        """Stop checking ``entity`` (it closed)."""
        with self._lock:
            self._watched.pop(id(entity), None)

    def _follow(self) -> None:
        graph = self._graph
        while not graph.closed:
            seen = graph.version
            with self._lock:
                watched = list(self._watched.values())
            if watched:
                try:
                    self._check(watched)
                except Exception:  # the session closes under it
                    _log.debug('checking the types of a topic failed', exc_info=True)
            self.checked = seen
            graph.wait_until(functools.partial(_changed_since, graph, seen), interruptible=False)

    def _check(self, watched: list[_Watched]) -> None:
        graph = self._graph
        on_key: dict[tuple[str, str], list[Endpoint]] = {}
        for endpoint in graph.endpoints(_KINDS):
            on_key.setdefault((endpoint.wire, endpoint.key), []).append(endpoint)
        for mine in watched:
            for other in on_key.get((mine.wire, mine.key), ()):
                if other.type_name != mine.type_name:
                    self._warn(mine, other, graph)

    def _warn(self, mine: _Watched, other: Endpoint, graph: Graph) -> None:
        node = other.node
        if node is None:  # a ROS node behind a bridge, or a zros one whose owner is on its way
            node = next((b.node_name for b in graph.bridges() if b.zid == other.zid), None)
            if node is None:
                return
        pair = frozenset({(mine.node, mine.type_name), (node, other.type_name)})
        with self._lock:
            if (mine.wire, mine.key, pair) in self._warned:
                return
            self._warned.add((mine.wire, mine.key, pair))
        _log.warning(
            '%s: the %s of %s carries %s, but the %s of %s carries %s: %s',
            mine.topic, _WORDS[mine.kind], mine.node, mine.type_name,
            _WORDS[other.kind], node, other.type_name, mine.conflict,
        )  # fmt: skip


def _changed_since(graph: Graph, version: int) -> bool:
    return graph.version != version


#: the watch of a session, made with its first publisher or subscriber
type_watch_of = PerSession(TypeWatch)


def forget_types(entity: Entity) -> None:
    """Stop checking ``entity``'s type (it closes)."""
    watch = type_watch_of.peek(entity.context.transport)
    if watch is not None:
        watch.forget(entity)
