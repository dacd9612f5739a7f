"""The wire of zenoh-bridge-ros2dds: keys named by the ROS name under the bridge's namespace,
an ``@ros2_lv`` token per entity (and zros's ``@zros_lv`` owner link), no attachments.

The bridges present when a node starts set its namespace and whether tokens may carry the type
hash; they answer in their admin space (``@/<zid>/ros2/version`` and ``.../config``).
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, ClassVar

from zenoh import SampleKind, ZError

from zros.cdr.hashing import type_hash
from zros.keyexpr.bridge import (
    BRIDGE_TOKENS,
    CONFIG_SELECTOR,
    ENTITY_TOKENS,
    VERSION_SELECTOR,
    BridgeScheme,
    EntityToken,
    admin_key,
    bridge_zid,
    ros_name,
)
from zros.keyexpr.errors import TokenError
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.owners import (
    ZROS_TOKENS,
    OwnedEntity,
    OwnedNode,
    entity_token,
    node_token,
    parse_owner_token,
)
from zros.qos import QoS
from zros.transport import Transport
from zros.transport.config import SessionDefaults
from zros.transport.per_session import PerSession
from zros.wire.base import Wire, WireEntity
from zros.wire.schemes import WireOption
from zros.wire.tokens import (
    BridgeInfo,
    Endpoint,
    TokenHandler,
    TokenSample,
    TokenView,
    graph_log,
    keep_token,
)

if TYPE_CHECKING:
    from zenoh import Session

    from zros.cdr import JsonValue, TypeRegistry

_log = logging.getLogger('zros')


def _admin_answers(
    session: Session, selectors: tuple[str, ...], timeout: float
) -> dict[str, dict[str, JsonValue]]:
    """``{zid: {item: json}}`` from the admin spaces answering ``selectors``."""
    found: dict[str, dict[str, JsonValue]] = {}
    for selector in selectors:
        for reply in session.get(selector, timeout=timeout):
            if reply.ok is None:
                continue
            parts = str(reply.ok.key_expr).split('/')
            if len(parts) < 4:
                continue
            try:
                value = json.loads(reply.ok.payload.to_string())
            except ValueError:
                continue
            found.setdefault(parts[1], {})[parts[3]] = value
    return found


def query_bridges(session: Session, timeout: float = 1.0) -> dict[str, BridgeInfo]:
    """Ask every reachable bridge for its version and configuration (ends at once without any)."""
    found = _admin_answers(session, (VERSION_SELECTOR, CONFIG_SELECTOR), timeout)
    return {zid: BridgeInfo.from_admin(zid, answers) for zid, answers in found.items()}


def ask_bridge(session: Session, zid: str, timeout: float = 2.0) -> BridgeInfo:
    """The version and configuration of the bridge ``zid`` (fields None where it is silent)."""
    selectors = (admin_key(zid, 'version'), admin_key(zid, 'config'))
    return BridgeInfo.from_admin(zid, _admin_answers(session, selectors, timeout).get(zid, {}))


class BridgeTokens(TokenView):
    """What a session hears of the bridges: each bridge (its ``@ros2_lv`` token, then its
    admin space), the entities they and zros nodes announce, and zros's ``@zros_lv`` tokens
    naming the node that owns each of zros's entities."""

    def __init__(self, session: Session, changed: Callable[[], None]) -> None:
        super().__init__(session, changed)
        self._entities: dict[str, EntityToken] = {}  # token key -> token
        self._owners: dict[tuple[str, EntityKind, str, str], str] = {}  # -> zros node
        self._owner_tokens: dict[str, tuple[str, EntityKind, str, str, str]] = {}
        self._nodes: dict[str, tuple[str, str]] = {}  # token key -> (zid, node fqn)
        self._bridges: dict[str, BridgeInfo] = {}

    def selectors(self) -> list[tuple[str, TokenHandler]]:
        """Entities' tokens, the bridges' own, and zros's owner tokens."""
        return [
            (ENTITY_TOKENS, self._on_entity),
            (BRIDGE_TOKENS, self._on_entity),
            (ZROS_TOKENS, self._on_zros),
        ]

    def _on_entity(self, sample: TokenSample) -> None:
        key = str(sample.key_expr)
        alive = sample.kind == SampleKind.PUT
        zid = bridge_zid(key)
        if zid is not None:
            with self.lock:
                if alive:
                    self._bridges.setdefault(zid, BridgeInfo(zid))
                else:
                    self._bridges.pop(zid, None)
            if alive:
                threading.Thread(target=self._ask_bridge, args=(zid,), daemon=True).start()
            self.changed()
            return
        try:
            token = EntityToken.parse(key)
        except TokenError as exc:
            graph_log.debug('ignoring a malformed token %s: %s', key, exc)
            return
        if token is None:
            return
        with self.lock:
            keep_token(self._entities, key, token, alive)
        self.changed()

    def _on_zros(self, sample: TokenSample) -> None:
        key = str(sample.key_expr)
        alive = sample.kind == SampleKind.PUT
        token = parse_owner_token(key)
        with self.lock:
            if isinstance(token, OwnedNode):
                keep_token(self._nodes, key, (token.zid, token.node), alive)
            elif isinstance(token, OwnedEntity):
                if alive:
                    self._owners[token.entity] = token.node
                    self._owner_tokens[key] = (*token.entity, token.node)
                else:
                    self._owners.pop(token.entity, None)
                    self._owner_tokens.pop(key, None)
            else:
                return
        self.changed()

    def _ask_bridge(self, zid: str) -> None:
        try:
            info = ask_bridge(self.session, zid, timeout=2.0)
        except ZError as exc:  # a bridge that does not answer keeps its token entry
            graph_log.debug('bridge %s admin space: %s', zid, exc)
            info = BridgeInfo(zid)
        with self.lock:
            if zid not in self._bridges or self.closed:
                return
            self._bridges[zid] = info
        self.changed()

    def endpoints(self) -> list[Endpoint]:
        """The entities announced, with the zros node owning each where one does."""
        with self.lock:
            tokens = list(self._entities.values())
            owners = dict(self._owners)
        result = []
        for token in tokens:
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
                    BridgeWire.name,
                    type_hash=type_hash,
                    naming=ros_name,
                )
            )
        return result

    def nodes(self) -> set[str]:
        """zros nodes, and the one ROS node each bridge shows."""
        with self.lock:
            names = {fqn for _, fqn in self._nodes.values()}
            return names | {bridge.node_name for bridge in self._bridges.values()}

    def node_instances(self) -> list[str]:
        """Each zros node (one token per session and name), and each bridge's node."""
        with self.lock:
            names = [fqn for _, fqn in self._nodes.values()]
            return sorted(names + [bridge.node_name for bridge in self._bridges.values()])

    def present(self) -> bool:
        """Bridges, or zros nodes speaking to bridges."""
        with self.lock:
            return bool(self._bridges or self._entities or self._nodes)

    def bridges(self) -> list[BridgeInfo]:
        """The bridges present, with their version and namespace once they answered."""
        with self.lock:
            return sorted(self._bridges.values(), key=lambda b: b.zid)

    def settled(self) -> bool:
        """Whether every bridge told its version."""
        return all(bridge.version is not None for bridge in self.bridges())


#: the bridges that answered the first time a node of a session asked
bridges_at_start = PerSession(lambda transport: query_bridges(transport.session, timeout=1.0))


def bridge_scheme(transport: Transport, namespace: str | None) -> BridgeScheme:
    """Keys for the bridges present: their namespace, and the type hash if they take it."""
    bridges = bridges_at_start(transport)
    versions = [bridge.version_tuple for bridge in bridges.values()]
    send_type_hash = bool(versions) and all(v is not None and v >= (1, 0, 4) for v in versions)
    if namespace is None:
        found = {bridge.namespace for bridge in bridges.values() if bridge.namespace}
        namespace = found.pop() if len(found) == 1 else '/'
        if found:
            _log.warning(
                'bridges with different namespaces answered; using "/": pass '
                'bridge_namespace= to choose'
            )
    return BridgeScheme(namespace, send_type_hash)


class BridgeWire(Wire):
    """A node reaching ROS 2 behind zenoh-bridge-ros2dds."""

    name = 'bridge'
    token_view: ClassVar[type[TokenView]] = BridgeTokens
    type_conflict = (
        "a bridge's key is the topic's name alone, so each gets the other's messages and "
        'cannot read them: they fail to decode or decode as wrong values'
    )
    #: zenoh-bridge-ros2dds's: a client of the bridge at tcp/127.0.0.1:7447 (zenohd's port)
    session: ClassVar[SessionDefaults] = SessionDefaults()

    def __init__(
        self,
        transport: Transport,
        namespace: str,
        node_name: str,
        registry: TypeRegistry,
        settings: Mapping[str, WireOption],
    ) -> None:
        super().__init__(transport, namespace, node_name, registry, settings)
        bridge_namespace = settings.get('bridge_namespace')
        if bridge_namespace is not None and not isinstance(bridge_namespace, str):
            raise TypeError(f'bridge_namespace= is a str, not {bridge_namespace!r}')
        self.scheme: BridgeScheme = bridge_scheme(transport, bridge_namespace)

    @property
    def node_token(self) -> str:
        """The node's ``@zros_lv`` token (bridges have no node tokens)."""
        return node_token(self.transport.zid, self.node_fqn)

    def _type_hash(self, registry: TypeRegistry, type_name: str) -> str | None:
        return type_hash(registry, type_name) if self.scheme.send_type_hash else None

    def entity(
        self,
        kind: EntityKind,
        ros_name: str,
        type_name: str,
        registry: TypeRegistry,
        *,
        qos: QoS | None = None,
        announce: bool = True,
        owned: bool = True,
    ) -> WireEntity:
        """The key of the name, the bridge token and (``owned``) the node's owner token."""
        type_hash = self._type_hash(registry, type_name)
        key = self.scheme.data_key(ros_name, type_name, type_hash)
        if not announce:
            return WireEntity(key)
        zid = self.transport.zid
        token = self.scheme.token(
            kind, zid, ros_name, type_name, qos=qos if kind.has_qos else None,
            type_hash=type_hash,
        )  # fmt: skip
        if not owned:
            return WireEntity(key, (token,))
        owner = entity_token(zid, self.node_fqn, kind, key, type_name)
        return WireEntity(key, (owner, token))

    def unannounced(self, key: str) -> WireEntity:
        """An entity on ``key`` as is."""
        return WireEntity(key)

    def action_tokens(
        self, kind: EntityKind, ros_name: str, type_name: str, registry: TypeRegistry
    ) -> tuple[str, ...]:
        """One AS or AC token (and its owner link): the bridge routes the parts from it."""
        return self.entity(kind, ros_name, type_name, registry).tokens

    def announces_action_parts(self) -> bool:
        """No: the AS/AC token stands for them."""
        return False

    @staticmethod
    def any_type_key(key: str) -> str:
        """The key itself: bridge keys carry no type."""
        return key
