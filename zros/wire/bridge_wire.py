"""The wire of zenoh-bridge-ros2dds: keys named by the ROS name under the bridge's namespace,
an ``@ros2_lv`` token per entity (and zros's ``@zros_lv`` owner link), no attachments.

The bridges present when a node starts set its namespace and whether tokens may carry the type
hash; they answer in their admin space (``@/<zid>/ros2/version`` and ``.../config``).
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

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
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.owners import entity_token, node_token
from zros.qos import QoS
from zros.transport import Transport
from zros.transport.per_session import PerSession
from zros.wire.base import Wire, WireEntity
from zros.wire.schemes import WireOption

if TYPE_CHECKING:
    from zenoh import Session

    from zros.cdr import JsonValue, TypeRegistry

_log = logging.getLogger('zros')


@dataclass(frozen=True)
class BridgeInfo:
    """A zenoh-bridge-ros2dds on the network."""

    zid: str
    version: str | None = None  #: e.g. ``1.10.0`` (None until its admin space answered)
    namespace: str | None = None
    nodename: str | None = None

    @classmethod
    def from_admin(cls, zid: str, answers: dict[str, JsonValue]) -> BridgeInfo:
        """A bridge from the JSON its admin space gave (``version`` and ``config``)."""
        config = answers.get('config')
        settings: dict[str, JsonValue] = config if isinstance(config, dict) else {}
        version = answers.get('version')
        return cls(
            zid,
            str(version).lstrip('v') if version is not None else None,
            settings.get('namespace'),
            settings.get('nodename'),
        )

    @property
    def version_tuple(self) -> tuple[int, ...] | None:
        """The version as numbers, e.g. ``(1, 10, 0)``; None if unknown."""
        if not self.version:
            return None
        digits = self.version.lstrip('v').split('-')[0].split('.')
        try:
            return tuple(int(part) for part in digits)
        except ValueError:
            return None

    @property
    def node_name(self) -> str:
        """The one ROS node the bridge shows: ``<namespace>/<nodename>``."""
        namespace = self.namespace or '/'
        return namespace.rstrip('/') + '/' + (self.nodename or 'zenoh_bridge_ros2dds')


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


#: where the graph hears this scheme: the entities' tokens, and the bridges' own
BRIDGE_TOKEN_SELECTORS = (ENTITY_TOKENS, BRIDGE_TOKENS)


def parse_bridge_token(key: str) -> str | EntityToken | None:
    """What a token under :data:`BRIDGE_TOKEN_SELECTORS` announces: a bridge (its zid), an
    entity, or nothing the graph shows (None); TokenError for a malformed one."""
    return bridge_zid(key) or EntityToken.parse(key)


def bridged_name(key: str, namespace: str = '/') -> str:
    """The ROS name of a bridge key seen through a bridge with ``namespace``."""
    return ros_name(key, namespace)


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

    def __init__(
        self,
        transport: Transport,
        namespace: str,
        node_name: str,
        registry: TypeRegistry,
        *,
        bridge_namespace: str | None = None,
    ) -> None:
        super().__init__(transport, namespace, node_name, registry)
        self.scheme: BridgeScheme = bridge_scheme(transport, bridge_namespace)

    @classmethod
    def open(
        cls,
        transport: Transport,
        namespace: str,
        node_name: str,
        registry: TypeRegistry,
        settings: Mapping[str, WireOption],
    ) -> BridgeWire:
        """The wire with ``bridge_namespace`` from ``settings``."""
        bridge_namespace = settings.get('bridge_namespace')
        if bridge_namespace is not None and not isinstance(bridge_namespace, str):
            raise TypeError(f'bridge_namespace= is a str, not {bridge_namespace!r}')
        return cls(transport, namespace, node_name, registry, bridge_namespace=bridge_namespace)

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
