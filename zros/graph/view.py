"""A live view of the ROS graph, built from the liveliness tokens on the Zenoh network.

Bridges announce every ROS entity they route as ``@/<zid>/@ros2_lv/<kind>/...`` tokens, and
themselves as ``@/<zid>/@ros2_lv``; zros entities announce themselves the same way. zros nodes
also announce who they are in a key space of their own, ``@/<zid>/@zros_lv/...`` (bridges never
parse it: they abort on unknown forms under ``@ros2_lv``):

* ``@/<zid>/@zros_lv/NN/<node fqn, / as §>`` per node;
* ``@/<zid>/@zros_lv/EN/<node fqn>/<kind>/<key>/<type>`` per entity, to tell which node owns it.

The view follows tokens as they come and go (a closed session's tokens go within milliseconds, a
vanished one's within the Zenoh lease). A bridge's version and namespace come from its admin
space (``@/<zid>/ros2/version`` and ``/config``).

ROS 2 nodes running rmw_zenoh (and zros nodes on that wire) announce themselves and each entity
as ``@ros2_lv/<domain>/<zid>/<nid>/<eid>/<kind>/...``; the view parses those too. Their
endpoints' ``key`` is ``<domain>/<name>`` (what ``RmwZenohScheme.key`` gives) and ``wire`` says
which scheme announced an endpoint.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

from zenoh import Sample, SampleKind, ZError
from zenoh.handlers import FifoChannel

from zros.keyexpr.kinds import EntityKind, TokenError
from zros.keyexpr.owners import ZROS_TOKENS, OwnedEntity, OwnedNode, parse_owner_token
from zros.qos import QoS
from zros.runtime.entity import Undeclarable
from zros.runtime.signal import Signal
from zros.transport import Transport
from zros.transport.per_session import PerSession
from zros.wire import (
    BRIDGE_TOKEN_SELECTORS,
    RMW_TOKEN_SELECTOR,
    BridgeInfo,
    EndpointToken,
    EntityToken,
    NodeToken,
    ask_bridge,
    bridged_name,
    endpoint_facts,
    parse_bridge_token,
    parse_rmw_token,
)

_log = logging.getLogger('zros.graph')

#: replies one graph refresh can hold per selector (tokens of a very large graph)
REFRESH_CAPACITY = 1_000_000
#: seconds a refresh's asks may wait for the network's answer: an answer ends an ask at once, so
#: this only bounds a router slow to answer (a loaded machine took over 2 s)
ANSWER_WITHIN = 15.0

_T = TypeVar('_T')


def _keep_token(table: dict[str, _T], key: str, token: _T, alive: bool) -> None:
    """Add ``token`` under ``key`` while it is alive; remove it once it is gone."""
    if alive:
        table[key] = token
    else:
        table.pop(key, None)


@dataclass(frozen=True)
class Endpoint:
    """One publisher, subscriber, service or action endpoint on the network."""

    kind: EntityKind
    zid: str  #: the Zenoh session announcing it (a bridge's, or a zros process's)
    key: str  #: its Zenoh key
    type_name: str
    qos: QoS | None  #: publishers and subscribers
    node: str | None  #: the node owning it, when known (zros nodes, rmw_zenoh nodes)
    wire: str = 'bridge'  #: the scheme that announced it: 'bridge' or 'rmw_zenoh'
    name: str | None = None  #: rmw_zenoh: the ROS name as announced
    gid: bytes | None = None  #: rmw_zenoh: the entity's GID (what ``ros2 topic info -v`` shows)
    type_hash: str | None = None  #: its type's RIHS01 hash, when announced

    def ros_name(self, namespace: str = '/') -> str:
        """Its ROS name (through a bridge with ``namespace``, for bridged endpoints)."""
        return self.name if self.name is not None else bridged_name(self.key, namespace)

    @property
    def is_bridged(self) -> bool:
        """Whether a bridge announces it (a ROS entity behind that bridge)."""
        return self.node is None


class Graph:
    """What one session sees of the ROS graph; updated by Zenoh as tokens come and go."""

    def __init__(self, transport: Transport) -> None:
        session = self._session = transport.session
        self._lock = threading.Lock()
        self._entities: dict[str, EntityToken] = {}  # token key -> token
        self._owners: dict[tuple[str, EntityKind, str, str], str] = {}  # -> zros node
        self._owner_tokens: dict[str, tuple[str, EntityKind, str, str, str]] = {}
        self._nodes: dict[str, tuple[str, str]] = {}  # token key -> (zid, node fqn)
        self._bridges: dict[str, BridgeInfo] = {}
        self._rmw_entities: dict[str, EndpointToken] = {}  # token key -> rmw_zenoh endpoint
        self._rmw_nodes: dict[str, NodeToken] = {}  # token key -> rmw_zenoh node
        self._changed = Signal()
        self.version = 0  #: bumped on every change
        self._closed = False
        liveliness = session.liveliness()
        self._subscribers: list[Undeclarable] = [
            liveliness.declare_subscriber(selector, handler, history=True)
            for selector, handler in self._selectors()
        ]
        transport.on_close(self.close)

    def _selectors(self) -> list[tuple[str, Callable[[Sample], None]]]:
        """Where the view hears each scheme's tokens, and what handles them."""
        bridge = [(selector, self._on_entity) for selector in BRIDGE_TOKEN_SELECTORS]
        return [*bridge, (ZROS_TOKENS, self._on_zros), (RMW_TOKEN_SELECTOR, self._on_rmw)]

    # --- token handling, on Zenoh's threads -----------------------------------------------------

    def _bump(self) -> None:
        self.version += 1
        if self._changed:
            self._changed.notify()

    def _on_entity(self, sample: Sample) -> None:
        key = str(sample.key_expr)
        alive = sample.kind == SampleKind.PUT
        try:
            token = parse_bridge_token(key)
        except TokenError as exc:
            _log.debug('ignoring a malformed token %s: %s', key, exc)
            return
        if isinstance(token, str):  # a bridge's own token
            zid = token
            with self._lock:
                if alive:
                    self._bridges.setdefault(zid, BridgeInfo(zid))
                else:
                    self._bridges.pop(zid, None)
            if alive:
                threading.Thread(target=self._ask_bridge, args=(zid,), daemon=True).start()
            self._bump()
            return
        if token is None:
            return
        with self._lock:
            if alive:
                self._entities[key] = token
            else:
                self._entities.pop(key, None)
        self._bump()

    def _on_zros(self, sample: Sample) -> None:
        key = str(sample.key_expr)
        alive = sample.kind == SampleKind.PUT
        token = parse_owner_token(key)
        with self._lock:
            if isinstance(token, OwnedNode):
                if alive:
                    self._nodes[key] = (token.zid, token.node)
                else:
                    self._nodes.pop(key, None)
            elif isinstance(token, OwnedEntity):
                if alive:
                    self._owners[token.entity] = token.node
                    self._owner_tokens[key] = (*token.entity, token.node)
                else:
                    self._owners.pop(token.entity, None)
                    self._owner_tokens.pop(key, None)
            else:
                return
        self._bump()

    def _on_rmw(self, sample: Sample) -> None:
        key = str(sample.key_expr)
        alive = sample.kind == SampleKind.PUT
        try:
            token = parse_rmw_token(key)
        except TokenError as exc:
            _log.debug('ignoring a malformed rmw_zenoh token %s: %s', key, exc)
            return
        with self._lock:
            if isinstance(token, NodeToken):
                _keep_token(self._rmw_nodes, key, token, alive)
            else:
                _keep_token(self._rmw_entities, key, token, alive)
        self._bump()

    def _ask_bridge(self, zid: str) -> None:
        try:
            info = ask_bridge(self._session, zid, timeout=2.0)
        except ZError as exc:  # a bridge that does not answer keeps its token entry
            _log.debug('bridge %s admin space: %s', zid, exc)
            info = BridgeInfo(zid)
        with self._lock:
            if zid not in self._bridges or self._closed:
                return
            self._bridges[zid] = info
        self._bump()

    def refresh(self, timeout: float = 2.0) -> None:
        """Ask the network for every token now, and wait up to ``timeout`` seconds more until
        bridges told their version.

        The view fills by itself shortly after a session opens; a command-line tool that looks
        once calls this to see the whole graph at once. The asks end when the network has
        answered them (at once, normally), within :data:`ANSWER_WITHIN` seconds.
        """
        liveliness = self._session.liveliness()
        # one after another, each with the whole time: with one budget for all, a slow first
        # answer on a loaded machine left the last ones 50 ms; asked all at once, some answers
        # came back short under load (2 of 12 `zros action info` missed the node's name)
        within = max(timeout, ANSWER_WITHIN)
        for selector, handler in self._selectors():
            # a FIFO of Zenoh's default size (256) that fills while this thread takes the GIL
            # back from the graph's callbacks stalls the session: give it room for any graph
            replies = liveliness.get(
                selector, handler=FifoChannel(REFRESH_CAPACITY), timeout=within
            )
            for reply in replies:
                if reply.ok is not None:
                    handler(reply.ok)
        self.wait_until(lambda: all(b.version is not None for b in self.bridges()), timeout)

    # --- queries ------------------------------------------------------------------------------

    def endpoints(self, kinds: tuple[EntityKind, ...] | None = None) -> list[Endpoint]:
        """Every endpoint known, optionally of some kinds only."""
        with self._lock:
            tokens = list(self._entities.values())
            owners = dict(self._owners)
            rmw = list(self._rmw_entities.items())
        result = []
        for token in tokens:
            if kinds is not None and token.kind not in kinds:
                continue
            owner = owners.get((token.zid, token.kind, token.key, token.type_name))
            qos = token.qos.to_qos(token.kind is EntityKind.PUBLISHER) if token.qos else None
            type_hash = token.qos.type_hash if token.qos else None
            result.append(
                Endpoint(
                    token.kind,
                    token.zid,
                    token.key,
                    token.type_name,
                    qos,
                    owner,
                    type_hash=type_hash,
                )
            )
        for token_key, entity in rmw:
            if kinds is not None and entity.kind not in kinds:
                continue
            key, entity_gid, type_hash = endpoint_facts(token_key, entity)
            result.append(
                Endpoint(
                    entity.kind,
                    entity.node.zid,
                    key,
                    entity.type_name,
                    entity.qos.to_qos(),
                    entity.node.fully_qualified_name,
                    'rmw_zenoh',
                    entity.topic,
                    entity_gid,
                    type_hash,
                )
            )
        return sorted(result, key=lambda e: (e.key, e.kind.value, e.zid))

    def _names(self, kinds: tuple[EntityKind, ...], namespace: str) -> dict[str, list[str]]:
        names: dict[str, set[str]] = {}
        for endpoint in self.endpoints(kinds):
            names.setdefault(endpoint.ros_name(namespace), set()).add(endpoint.type_name)
        return {name: sorted(types) for name, types in sorted(names.items())}

    def topics(self, namespace: str = '/') -> dict[str, list[str]]:
        """Topic names (as seen through a bridge with ``namespace``) and their types."""
        return self._names((EntityKind.PUBLISHER, EntityKind.SUBSCRIBER), namespace)

    def services(self, namespace: str = '/') -> dict[str, list[str]]:
        """Service names and types (servers or clients announced)."""
        return self._names((EntityKind.SERVICE_SERVER, EntityKind.SERVICE_CLIENT), namespace)

    def actions(self, namespace: str = '/') -> dict[str, list[str]]:
        """Action names and types (servers or clients announced; under rmw_zenoh, found by
        their ``send_goal`` services as ROS finds them)."""
        names = self._names((EntityKind.ACTION_SERVER, EntityKind.ACTION_CLIENT), namespace)
        suffix = '/_action/send_goal'
        for name, types in self.services(namespace).items():
            if name.endswith(suffix):
                found = [t[: -len('_SendGoal')] for t in types if t.endswith('_SendGoal')]
                if found:
                    action = names.setdefault(name[: -len(suffix)], [])
                    action[:] = sorted(set(action) | set(found))
        return dict(sorted(names.items()))

    def publishers(self, key: str) -> list[Endpoint]:
        """The publishers announced on a Zenoh key."""
        return [e for e in self.endpoints((EntityKind.PUBLISHER,)) if e.key == key]

    def subscribers(self, key: str) -> list[Endpoint]:
        """The subscribers announced on a Zenoh key."""
        return [e for e in self.endpoints((EntityKind.SUBSCRIBER,)) if e.key == key]

    def bridges(self) -> list[BridgeInfo]:
        """The bridges present, with their version and namespace once they answered."""
        with self._lock:
            return sorted(self._bridges.values(), key=lambda b: b.zid)

    def nodes(self) -> list[str]:
        """Fully qualified names of the zros nodes and of the bridges' ROS nodes."""
        with self._lock:
            names = {fqn for _, fqn in self._nodes.values()}
            names |= {bridge.node_name for bridge in self._bridges.values()}
            names |= {node.fully_qualified_name for node in self._rmw_nodes.values()}
            names |= {e.node.fully_qualified_name for e in self._rmw_entities.values()}
        return sorted(names)

    def wires(self) -> list[str]:
        """The wire schemes present on the network: ``'bridge'`` (bridges, or zros nodes
        speaking to bridges) and ``'rmw_zenoh'`` (nodes running rmw_zenoh, zros ones included)."""
        with self._lock:
            found = set()
            if self._bridges or self._entities or self._nodes:
                found.add('bridge')
            if self._rmw_nodes or self._rmw_entities:
                found.add('rmw_zenoh')
        return sorted(found)

    def node_endpoints(self, node_fqn: str) -> list[Endpoint]:
        """What a zros node announced (its publishers, subscribers, services...)."""
        return [e for e in self.endpoints() if e.node == node_fqn]

    def wait_until(
        self,
        predicate: Callable[[], object],
        timeout: float | None = None,
        *,
        interruptible: bool = True,
    ) -> bool:
        """Wait until ``predicate()`` is true, re-checking at every change of the graph;
        whether it became true (False on timeout, once closed, and after Ctrl-C unless not
        ``interruptible``)."""
        self._changed.wait_for(lambda: predicate() or self._closed, timeout, interruptible)
        return bool(predicate())

    def close(self) -> None:
        """Stop following the network's announcements."""
        if self._closed:
            return
        self._closed = True
        for subscriber in self._subscribers:
            try:
                subscriber.undeclare()
            except ZError:  # the session may be closing already
                _log.debug('undeclaring a graph subscriber failed', exc_info=True)
        self._changed.notify()


#: the graph of a session, made on first use and closed with it (shared by its nodes)
graph_of = PerSession(Graph)
