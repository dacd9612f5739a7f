"""The key expressions and liveliness tokens of rmw_zenoh (ROS 2's Zenoh middleware).

See ``shared/specs/rmw-zenoh-protocol.md`` §1 to §3. Data keys are
``<domain>/<name>/<dds type>/<type hash>``; graph tokens are
``@ros2_lv/<domain>/<zid>/<nid>/<eid>/<kind>/<enclave>/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]``
with ``/`` mangled to ``%`` inside a chunk. An entity's GID is the XXH3-128 of its token.
Everything here is a pure function of its arguments.
"""

from __future__ import annotations

import itertools
import re
import threading
from dataclasses import dataclass, field

from zros.keyexpr.errors import TokenError
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.names import validate_full_name, validate_namespace, validate_node_name
from zros.keyexpr.xxh3 import xxh3_128
from zros.qos import Durability, History, QoS, Reliability

TOKEN_PREFIX = '@ros2_lv'
NODE_KIND = 'NN'
#: the hash chunk of Humble's rmw_zenoh (0.1.x), whose type supports carry no REP-2011 hash
HASH_NOT_SUPPORTED = 'TypeHashNotSupported'
#: the kinds of endpoint tokens (rmw_zenoh has no action kinds: actions are their parts)
ENDPOINT_KINDS = (
    EntityKind.PUBLISHER,
    EntityKind.SUBSCRIBER,
    EntityKind.SERVICE_SERVER,
    EntityKind.SERVICE_CLIENT,
)

_TYPE_NAME = re.compile(r'^([A-Za-z][A-Za-z0-9_]*)/(msg|srv|action)/([A-Za-z][A-Za-z0-9_]*)$')
_DDS_NAME = re.compile(r'^([A-Za-z][A-Za-z0-9_]*)::(msg|srv|action)::dds_::([A-Za-z0-9_]+)_$')
_TYPE_HASH = re.compile(r'^RIHS01_[0-9a-f]{64}$')
_ZID = re.compile(r'^[0-9a-f]{1,32}$')


def token_selector(domain: int) -> str:
    """The liveliness selector of every rmw_zenoh token of a domain."""
    return f'{TOKEN_PREFIX}/{domain}/**'


#: every rmw_zenoh token of every domain (``@ros2_lv`` is a verbatim chunk: ``**`` misses it)
ALL_TOKENS = f'{TOKEN_PREFIX}/**'


def mangle(name: str) -> str:
    """One token chunk for a slash-separated name: every ``/`` becomes ``%``."""
    return name.replace('/', '%')


def demangle(chunk: str) -> str:
    """Undo rmw_zenoh's mangling of ``/`` (as ``%``) in one token chunk."""
    return chunk.replace('%', '/')


def strip_slashes(name: str) -> str:
    """A name without one leading and one trailing ``/``, as rmw_zenoh puts it into keys."""
    if name.startswith('/'):
        name = name[1:]
    if name.endswith('/'):
        name = name[:-1]
    return name


def dds_type_name(type_name: str) -> str:
    """``pkg/msg/Name`` -> ``pkg::msg::dds_::Name_`` (services and action parts alike)."""
    match = _TYPE_NAME.match(type_name)
    if not match:
        raise TokenError(f'{type_name!r} is not a pkg/msg|srv|action/Name type name')
    package, kind, short = match.groups()
    return f'{package}::{kind}::dds_::{short}_'


def ros_type_name(dds_name: str) -> str:
    """``pkg::msg::dds_::Name_`` -> ``pkg/msg/Name``; other names are returned unchanged."""
    match = _DDS_NAME.match(dds_name)
    if not match:
        return dds_name
    package, kind, short = match.groups()
    return f'{package}/{kind}/{short}'


def check_type_hash(type_hash: str) -> str:
    """``type_hash`` if it is a RIHS01 hash or Humble's literal, else TokenError."""
    if type_hash != HASH_NOT_SUPPORTED and not _TYPE_HASH.match(type_hash):
        raise TokenError(f'{type_hash!r} is neither a RIHS01 hash nor {HASH_NOT_SUPPORTED}')
    return type_hash


def name_key(domain: int, ros_name: str) -> str:
    """``<domain>/<name>``: the part of a data key that names the topic or service."""
    validate_full_name(ros_name)
    _check_domain(domain)
    return f'{domain}/{strip_slashes(ros_name)}'


def data_key(domain: int, ros_name: str, type_name: str, type_hash: str) -> str:
    """The Zenoh key of a topic or service: ``<domain>/<name>/<dds type>/<hash>``."""
    base = name_key(domain, ros_name)
    return f'{base}/{dds_type_name(type_name)}/{check_type_hash(type_hash)}'


def gid(token: str) -> bytes:
    """The 16-byte GID rmw_zenoh derives from an entity's token (XXH3-128, low half first)."""
    low, high = xxh3_128(token.encode())
    return low.to_bytes(8, 'little') + high.to_bytes(8, 'little')


def _check_domain(domain: int) -> None:
    if isinstance(domain, bool) or not isinstance(domain, int) or domain < 0:
        raise TokenError(f'a domain id is a non-negative integer, not {domain!r}')


# --- the QoS chunk -----------------------------------------------------------------------------

#: RMW_DURATION_INFINITE as (seconds, nanoseconds)
INFINITE = (9223372036, 854775807)
#: rmw/types.h enum values
RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST, KEEP_ALL = 1, 2
AUTOMATIC = 1
DEFAULT_DEPTH = 42
_UNKNOWN = {'reliability': 3, 'durability': 3, 'history': 3, 'liveliness': 4}


@dataclass(frozen=True)
class RmwQoS:
    """A QoS profile as rmw_zenoh puts it in tokens (``rmw/types.h`` values, durations as
    ``(seconds, nanoseconds)``). The defaults are rmw_zenoh's default profile."""

    reliability: int = RELIABLE
    durability: int = VOLATILE
    history: int = KEEP_LAST
    depth: int = DEFAULT_DEPTH
    deadline: tuple[int, int] = INFINITE
    lifespan: tuple[int, int] = INFINITE
    liveliness: int = AUTOMATIC
    lease: tuple[int, int] = INFINITE

    @classmethod
    def from_qos(cls, qos: QoS) -> RmwQoS:
        """The profile of a zros QoS (deadline, lifespan and lease infinite)."""
        return cls(
            RELIABLE if qos.reliable else BEST_EFFORT,
            TRANSIENT_LOCAL if qos.transient_local else VOLATILE,
            KEEP_ALL if qos.keep_all else KEEP_LAST,
            qos.depth,
        )

    def to_qos(self) -> QoS:
        """The zros QoS closest to this profile (unknown values read as the defaults)."""
        keep_all = self.history == KEEP_ALL
        depth = self.depth if self.depth >= 1 else DEFAULT_DEPTH
        return QoS(
            depth,
            Reliability.BEST_EFFORT if self.reliability == BEST_EFFORT else Reliability.RELIABLE,
            Durability.TRANSIENT_LOCAL
            if self.durability == TRANSIENT_LOCAL
            else Durability.VOLATILE,
            History.KEEP_ALL if keep_all else History.KEEP_LAST,
        )

    def adapted(self) -> RmwQoS:
        """The profile rmw_zenoh announces: system defaults filled in, depth 0 -> 42,
        rcl's unspecified ``{0, 0}`` durations -> infinite. TokenError for UNKNOWN policies."""
        for name, unknown in _UNKNOWN.items():
            if getattr(self, name) == unknown:
                raise TokenError(f'rmw_zenoh refuses an entity whose {name} is UNKNOWN')
        default = RmwQoS()

        def policy(value: int, fallback: int, *aliases: int) -> int:
            # SYSTEM_DEFAULT (0) and BEST_AVAILABLE take rmw_zenoh's default
            return fallback if value in (0, *aliases) else value

        def duration(value: tuple[int, int]) -> tuple[int, int]:
            return INFINITE if value == (0, 0) else value

        return RmwQoS(
            policy(self.reliability, default.reliability, 4),
            policy(self.durability, default.durability, 4),
            policy(self.history, default.history),
            self.depth if self.depth > 0 else DEFAULT_DEPTH,
            duration(self.deadline),
            duration(self.lifespan),
            policy(self.liveliness, default.liveliness, 5),
            duration(self.lease),
        )

    def format(self) -> str:
        """The token chunk: each field written only where it differs from the default."""
        qos = self.adapted()
        default = RmwQoS()

        def value(mine: int, theirs: int) -> str:
            if mine < 0:
                raise TokenError(f'QoS value {mine} is negative')
            return '' if mine == theirs else str(mine)

        def pair(mine: tuple[int, int], theirs: tuple[int, int]) -> str:
            return f'{value(mine[0], theirs[0])},{value(mine[1], theirs[1])}'

        return ':'.join(
            (
                value(qos.reliability, default.reliability),
                value(qos.durability, default.durability),
                f'{value(qos.history, default.history)},{value(qos.depth, default.depth)}',
                pair(qos.deadline, default.deadline),
                pair(qos.lifespan, default.lifespan),
                f'{value(qos.liveliness, default.liveliness)},{pair(qos.lease, default.lease)}',
            )
        )

    @classmethod
    def parse(cls, chunk: str) -> RmwQoS:
        """Read a token's QoS chunk (empty fields are defaults); TokenError when malformed."""
        parts = chunk.split(':')
        if len(parts) < 6:
            raise TokenError(f'QoS chunk {chunk!r} has {len(parts)} ":" parts, expected 6')
        default = cls()

        def fields(part: str, count: int) -> list[str]:
            items = part.split(',')
            if len(items) < count:
                raise TokenError(f'QoS chunk {chunk!r}: {part!r} needs {count} "," parts')
            return items[:count]

        def number(text: str, fallback: int) -> int:
            if text == '':
                return fallback
            if not text.isdigit() or not text.isascii():
                raise TokenError(f'QoS chunk {chunk!r} has an invalid number {text!r}')
            return int(text)

        def pair(part: str, fallback: tuple[int, int]) -> tuple[int, int]:
            seconds, nanoseconds = fields(part, 2)
            return number(seconds, fallback[0]), number(nanoseconds, fallback[1])

        history, depth = fields(parts[2], 2)
        liveliness, lease_s, lease_ns = fields(parts[5], 3)
        return cls(
            number(parts[0], default.reliability),
            number(parts[1], default.durability),
            number(history, default.history),
            number(depth, default.depth),
            pair(parts[3], default.deadline),
            pair(parts[4], default.lifespan),
            number(liveliness, default.liveliness),
            (number(lease_s, default.lease[0]), number(lease_ns, default.lease[1])),
        )


# --- tokens ------------------------------------------------------------------------------------


def _chunk(text: str, what: str) -> str:
    chunk = mangle(text)
    if not chunk or any(char in chunk for char in '*$#?'):
        raise TokenError(f'{what} {text!r} cannot be a token chunk')
    return chunk


@dataclass(frozen=True)
class NodeToken:
    """A node on an rmw_zenoh network (the ``NN`` token)."""

    domain: int
    zid: str
    node_id: int
    namespace: str
    name: str
    enclave: str = '/'

    def format(self) -> str:
        """The liveliness key, checked to be one rmw_zenoh parses."""
        _check_domain(self.domain)
        if not _ZID.match(self.zid):
            raise TokenError(f'zid {self.zid!r} is not a lowercase hex Zenoh id')
        if self.node_id < 0:
            raise TokenError(f'node id {self.node_id} is negative')
        validate_namespace(self.namespace)
        validate_node_name(self.name)
        return (
            f'{TOKEN_PREFIX}/{self.domain}/{self.zid}/{self.node_id}/{self.node_id}/{NODE_KIND}/'
            f'{_chunk(self.enclave, "enclave")}/{mangle(self.namespace)}/{mangle(self.name)}'
        )

    @property
    def fully_qualified_name(self) -> str:
        return self.namespace.rstrip('/') + '/' + self.name


@dataclass(frozen=True)
class EndpointToken:
    """A publisher, subscription, service server or client on an rmw_zenoh network."""

    node: NodeToken
    entity_id: int
    kind: EntityKind
    topic: str  #: fully qualified topic or service name
    dds_type: str  #: ``pkg::msg::dds_::Name_``
    type_hash: str  #: ``RIHS01_...`` or ``TypeHashNotSupported``
    qos: RmwQoS = field(default_factory=RmwQoS)

    @property
    def type_name(self) -> str:
        """The ROS form of the type (``pkg/msg/Name``)."""
        return ros_type_name(self.dds_type)

    def format(self) -> str:
        """The liveliness key, checked to be one rmw_zenoh parses."""
        if self.kind not in ENDPOINT_KINDS:
            raise TokenError(f'rmw_zenoh has no {self.kind.name} tokens')
        if self.entity_id < 0:
            raise TokenError(f'entity id {self.entity_id} is negative')
        validate_full_name(self.topic)
        node = self.node.format().split('/')
        node[4], node[5] = str(self.entity_id), self.kind.value
        return '/'.join(
            [
                *node,
                mangle(self.topic),
                _chunk(self.dds_type, 'type'),
                check_type_hash(self.type_hash),
                self.qos.format(),
            ]
        )


def parse_token(key: str) -> NodeToken | EndpointToken:
    """Parse an rmw_zenoh liveliness key as rmw_zenoh does; TokenError when malformed.

    Extra trailing chunks (the ``backends:`` chunk of newer releases) are ignored.
    """
    parts = key.split('/')
    if len(parts) < 9 or parts[0] != TOKEN_PREFIX:
        raise TokenError(f'{key!r} is not an rmw_zenoh token')
    if any(not part for part in parts):
        raise TokenError(f'{key!r} has an empty chunk')
    try:
        domain, node_id, entity_id = int(parts[1]), int(parts[3]), int(parts[4])
    except ValueError:
        raise TokenError(f'{key!r} has a domain or id that is not a number') from None
    node = NodeToken(
        domain, parts[2], node_id, demangle(parts[7]), demangle(parts[8]), demangle(parts[6])
    )
    if parts[5] == NODE_KIND:
        return node
    try:
        kind = EntityKind(parts[5])
    except ValueError:
        kind = None
    if kind not in ENDPOINT_KINDS:
        raise TokenError(f'{key!r} has an unknown entity kind {parts[5]!r}')
    assert kind is not None
    if len(parts) < 13:
        raise TokenError(f'{key!r} has {len(parts)} chunks, an endpoint needs 13')
    return EndpointToken(
        node, entity_id, kind, demangle(parts[9]), demangle(parts[10]), demangle(parts[11]),
        RmwQoS.parse(parts[12]),
    )  # fmt: skip


# --- the scheme ------------------------------------------------------------------------------


class IdCounter:
    """Node and entity ids of one session: one counter for both, from 0 (as rmw_zenoh)."""

    def __init__(self) -> None:
        self._next = itertools.count()
        self._lock = threading.Lock()

    def __call__(self) -> int:
        with self._lock:
            return next(self._next)


class RmwZenohScheme:
    """Keys and tokens for joining a ROS 2 graph that runs rmw_zenoh, in ``domain``.

    ``humble`` writes ``TypeHashNotSupported`` in place of type hashes, as rmw_zenoh 0.1.x does.
    The interface is the one of :class:`zros.keyexpr.bridge.BridgeScheme`; ``token`` needs the
    owning node and an entity id here.
    """

    name = 'rmw_zenoh'
    namespace = '/'  #: no bridge namespace: names are the ROS names
    send_type_hash = True  #: keys and tokens carry the type hash
    attachments = True  #: every publication, request and reply carries an Attachment
    action_tokens = False  #: actions are announced by their parts (three services, two topics)

    def __init__(self, domain: int = 0, *, humble: bool = False, enclave: str = '/') -> None:
        _check_domain(domain)
        self.domain = domain
        self.humble = humble
        self.enclave = enclave

    def key(self, ros_name: str) -> str:
        """``<domain>/<name>``: how the graph identifies a topic or service of this scheme."""
        return name_key(self.domain, ros_name)

    def hash_chunk(self, type_hash: str | None) -> str:
        """The hash chunk for a type (Humble's literal, or the RIHS01 hash, which is needed)."""
        if self.humble:
            return HASH_NOT_SUPPORTED
        if type_hash is None:
            raise TokenError('rmw_zenoh keys need the type hash')
        return check_type_hash(type_hash)

    def data_key(self, ros_name: str, type_name: str, type_hash: str | None) -> str:
        """The Zenoh key to declare a publisher, subscriber, queryable or querier on."""
        return data_key(self.domain, ros_name, type_name, self.hash_chunk(type_hash))

    def node(self, zid: str, node_id: int, namespace: str, name: str) -> NodeToken:
        return NodeToken(self.domain, zid, node_id, namespace, name, self.enclave)

    def node_token(self, zid: str, node_id: int, namespace: str, name: str) -> str:
        """The ``NN`` token that makes a node visible by name."""
        return self.node(zid, node_id, namespace, name).format()

    def token(
        self,
        kind: EntityKind,
        zid: str,
        ros_name: str,
        type_name: str,
        *,
        qos: QoS | None = None,
        type_hash: str | None = None,
        node: NodeToken | None = None,
        entity_id: int | None = None,
    ) -> str:
        """The liveliness key announcing one entity of ``node`` (its GID is ``gid(token)``)."""
        if node is None or entity_id is None:
            raise TokenError('rmw_zenoh tokens name their node and entity id')
        if node.zid != zid:
            raise TokenError(f'node {node.name} belongs to session {node.zid}, not {zid}')
        return EndpointToken(
            node, entity_id, kind, ros_name, dds_type_name(type_name),
            self.hash_chunk(type_hash), RmwQoS.from_qos(qos or QoS()),
        ).format()  # fmt: skip

    def __repr__(self) -> str:
        humble = ' humble' if self.humble else ''
        return f'<RmwZenohScheme domain={self.domain}{humble}>'
