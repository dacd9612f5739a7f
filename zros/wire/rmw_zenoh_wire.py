"""The wire of rmw_zenoh (ROS 2's Zenoh middleware): keys with the type and its hash, one
``@ros2_lv`` token per entity whose XXH3 is the entity's GID, and the 33-byte attachment on
every publication, request and reply.

Subscribers accept only samples with a valid attachment, as rmw_zenoh does; servers admit a
query only with a valid attachment, no negative numbers and no repeat of a pending (GID,
number), and echo the number and GID with a fresh timestamp; clients ask every complete
queryable without consolidation and refuse a reply that does not echo their number.
Transient-local publishers add the sporadic heartbeat (reliable ones), subscribers heartbeat
recovery and subscriber detection.
"""

from __future__ import annotations

import itertools
import logging
import os
import struct
import threading
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, ClassVar, Protocol

from zenoh import ConsolidationMode, Query, QueryTarget, Sample, SampleKind, ZBytes, ext

from zros.cdr.hashing import type_hash
from zros.keyexpr.attachment import GID_SIZE, SIZE, Attachment
from zros.keyexpr.errors import AttachmentError, TokenError
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.rmw_zenoh import (
    ALL_TOKENS,
    EndpointToken,
    IdCounter,
    NodeToken,
    RmwZenohScheme,
    gid,
    name_key,
    parse_token,
)
from zros.qos import QoS
from zros.transport import Transport
from zros.transport.config import SessionDefaults
from zros.transport.per_session import PerSession
from zros.wire.base import (
    BatchCallback,
    PublisherOptions,
    Put,
    QueryOptions,
    SampleCallback,
    SubscriberOptions,
    Wire,
    WireEntity,
)
from zros.wire.requests import Requests
from zros.wire.schemes import WireOption
from zros.wire.tokens import (
    Endpoint,
    TokenHandler,
    TokenSample,
    TokenView,
    graph_log,
    keep_token,
)

if TYPE_CHECKING:
    from zenoh import Session

    from zros.cdr import TypeRegistry

_log = logging.getLogger('zros')


#: node and entity ids of a session's tokens: one counter for both, from 0 (as rmw_zenoh)
class Attached(Protocol):
    """A sample or query: what may carry an attachment."""

    @property
    def attachment(self) -> ZBytes | None:
        """The attachment, if any."""


entity_ids = PerSession(lambda transport: IdCounter())


def has_attachment(carrier: Attached) -> bool:
    """Whether a sample carries a valid rmw_zenoh attachment (fast for the 33-byte form)."""
    raw = carrier.attachment
    if raw is None:
        return False
    data = raw.to_bytes()
    if len(data) == SIZE:
        return bool(data[16] == GID_SIZE)
    try:
        Attachment.decode(data)
    except AttachmentError:
        return False
    return True


def read_attachment(carrier: Attached) -> Attachment | None:
    """The rmw_zenoh attachment of a sample, query or reply; None if absent or malformed."""
    raw = carrier.attachment
    if raw is None:
        return None
    try:
        return Attachment.decode(raw.to_bytes())
    except AttachmentError:
        return None


class SequenceNumbers:
    """The attachments of one sending entity: sequence numbers from 1, the time, its GID."""

    _pack = struct.Struct('<qqB16s').pack  # the 33-byte form of Attachment.encode

    def __init__(self, entity_gid: bytes) -> None:
        if len(entity_gid) != GID_SIZE:
            raise AttachmentError(f'a GID has {GID_SIZE} bytes, not {len(entity_gid)}')
        self.gid = entity_gid
        self._numbers = itertools.count(1)

    def next(self) -> bytes:
        """The attachment of the next publication or request."""
        return self._pack(next(self._numbers), time.time_ns(), GID_SIZE, self.gid)

    def sender(self, put: Put) -> Callable[[bytes | bytearray], None]:
        """``put(data, attachment=...)`` with the next attachment, everything bound once (a
        publisher's hot path: two calls less per message than going through :meth:`next`)."""
        pack, numbers, now, gid = self._pack, self._numbers, time.time_ns, self.gid

        def send(data: bytes | bytearray) -> None:
            put(data, attachment=pack(next(numbers), now(), GID_SIZE, gid))

        return send


class AttachedRequests(Requests):
    """Requests admitted by rmw_zenoh's rules, answered with the echoed attachment."""

    def __init__(self, name: str, error_prefix: str) -> None:
        super().__init__(name, error_prefix)
        self._pending: dict[int, tuple[bytes, int]] = {}  # id(query) -> (client GID, seq)
        self._keys: set[tuple[bytes, int]] = set()
        self._lock = threading.Lock()
        self._warned = False

    def admit(self, query: Query) -> bool:
        """Whether ``query`` passes rmw_zenoh's rules; refused ones got their error reply."""
        attachment = read_attachment(query)
        reason = None
        if attachment is None:
            reason = f'a request to {self.name} has no valid rmw_zenoh attachment'
        elif attachment.sequence_number < 0 or attachment.source_timestamp < 0:
            reason = f'a request to {self.name} has a negative sequence number or timestamp'
        else:
            key = (attachment.gid, attachment.sequence_number)
            with self._lock:
                fresh = key not in self._keys
                if fresh:
                    self._keys.add(key)
                    self._pending[id(query)] = key
            if fresh:
                return True
            reason = (
                f'a request to {self.name} repeats sequence number '
                f'{attachment.sequence_number} of a pending request of the same client'
            )
        if not self._warned:  # once per server: a broken client may send many
            self._warned = True
            _log.warning('%s: refused (reported once)', reason)
        self.fail(query, reason)
        return False

    def _reply_attachment(self, query: Query) -> bytes | None:
        request = read_attachment(query)
        if request is None:
            return None
        return Attachment(request.sequence_number, time.time_ns(), request.gid).encode()

    def _forget(self, query: Query) -> None:
        with self._lock:
            key = self._pending.pop(id(query), None)
            if key is not None:
                self._keys.discard(key)


class RmwZenohEntity(WireEntity):
    """An entity on the rmw_zenoh wire: what it sends carries its GID and a number."""

    rejection = 'it has no valid rmw_zenoh attachment (rmw_zenoh drops such messages)'

    def admitting(self, callback: BatchCallback, rejected: SampleCallback) -> BatchCallback:
        """Only samples with a valid attachment, as rmw_zenoh (:func:`has_attachment`, its
        test of the usual 33-byte form inlined: a call per sample cost 150 ns, a twentieth of
        a small message's way through a subscriber)."""

        def on_samples(samples: list[Sample]) -> None:
            admitted = []
            for sample in samples:
                raw = sample.attachment
                if raw is not None and (
                    raw.to_bytes()[16] == GID_SIZE if len(raw) == SIZE else has_attachment(sample)
                ):
                    admitted.append(sample)
                else:
                    rejected(sample)
            if admitted:
                callback(admitted)

        return on_samples

    def __init__(self, key: str, tokens: tuple[str, ...] = (), gid: bytes | None = None) -> None:
        super().__init__(key, tokens, gid)
        self._numbers: SequenceNumbers | None = None
        self._numbers_lock = threading.Lock()

    def _sequence(self) -> SequenceNumbers:
        numbers = self._numbers
        if numbers is None:
            with self._numbers_lock:
                if self._numbers is None:
                    if self.gid is None:
                        raise AttachmentError(f'the entity on {self.key} has no GID to send with')
                    self._numbers = SequenceNumbers(self.gid)
                numbers = self._numbers
        return numbers

    def _next_attachment(self) -> bytes:
        return self._sequence().next()

    def sender(self, put: Put) -> Callable[[bytes | bytearray], None]:
        """``put`` with the next attachment (an entity without a GID raises when it sends)."""
        if self.gid is None:

            def refuse(data: bytes | bytearray) -> None:
                self._sequence()  # raises: no GID to send with

            return refuse
        return self._sequence().sender(put)

    def publisher_options(self, qos: QoS) -> PublisherOptions:
        """Reliable ones send rmw_zenoh's sporadic heartbeat."""
        if not qos.reliable:
            return {}
        return {
            'sample_miss_detection': ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=0.5)
        }

    def subscriber_options(self, qos: QoS) -> SubscriberOptions:
        """Heartbeat recovery (reliable ones) and subscriber detection, as rmw_zenoh's."""
        options: SubscriberOptions = {'subscriber_detection': True}
        if qos.reliable:
            options['recovery'] = ext.RecoveryConfig(periodic_queries=None, heartbeat=True)
        return options

    def requests(self, name: str, error_prefix: str) -> Requests:
        """Requests admitted by rmw_zenoh's rules."""
        return AttachedRequests(name, error_prefix)

    def request_attachment(self) -> bytes | None:
        """The next request's attachment."""
        return self._next_attachment()

    def query_options(self, attachment: bytes | None) -> QueryOptions:
        """Every complete queryable, no consolidation, and the attachment."""
        return {
            'attachment': attachment,
            'target': QueryTarget.ALL_COMPLETE,
            'consolidation': ConsolidationMode.NONE,
        }

    def reply_problem(self, reply: Sample, attachment: bytes | None) -> str | None:
        """Why ``reply`` does not echo the number of the request that carried ``attachment``."""
        if attachment is None:
            return None
        echoed = read_attachment(reply)
        if echoed is None:
            return 'its reply carries no valid rmw_zenoh attachment'
        expected = Attachment.decode(attachment).sequence_number
        if echoed.sequence_number != expected:
            return f'its reply answers request {echoed.sequence_number}, not request {expected}'
        return None


class RmwZenohTokens(TokenView):
    """What a session hears of rmw_zenoh: ``@ros2_lv/<domain>/...`` node and entity tokens
    of every domain (ROS 2 nodes running rmw_zenoh, and zros nodes on that wire)."""

    def __init__(self, session: Session, changed: Callable[[], None]) -> None:
        super().__init__(session, changed)
        self._entities: dict[str, EndpointToken] = {}  # token key -> endpoint
        self._nodes: dict[str, NodeToken] = {}  # token key -> node

    def selectors(self) -> list[tuple[str, TokenHandler]]:
        """Every domain's tokens."""
        return [(ALL_TOKENS, self._on_token)]

    def _on_token(self, sample: TokenSample) -> None:
        key = str(sample.key_expr)
        alive = sample.kind == SampleKind.PUT
        try:
            token = parse_token(key)
        except TokenError as exc:
            graph_log.debug('ignoring a malformed rmw_zenoh token %s: %s', key, exc)
            return
        with self.lock:
            if isinstance(token, NodeToken):
                keep_token(self._nodes, key, token, alive)
            else:
                keep_token(self._entities, key, token, alive)
        self.changed()

    def endpoints(self) -> list[Endpoint]:
        """The entities announced: key ``<domain>/<name>``, the owning node, the GID (the
        XXH3 of the token) and the type hash (none from Humble)."""
        with self.lock:
            entities = list(self._entities.items())
        return [
            Endpoint(
                entity.kind,
                entity.node.zid,
                name_key(entity.node.domain, entity.topic),
                entity.type_name,
                entity.qos.to_qos(),
                entity.node.fully_qualified_name,
                RmwZenohWire.name,
                entity.topic,
                gid(key),
                entity.type_hash if entity.type_hash.startswith('RIHS01_') else None,
            )
            for key, entity in entities
        ]

    def nodes(self) -> set[str]:
        """The nodes announced, and those only their entities name."""
        with self.lock:
            names = {node.fully_qualified_name for node in self._nodes.values()}
            return names | {e.node.fully_qualified_name for e in self._entities.values()}

    def node_instances(self) -> list[str]:
        """Each node (a session and node id), announced or only named by its entities."""
        with self.lock:
            nodes = set(self._nodes.values()) | {e.node for e in self._entities.values()}
        return sorted(node.fully_qualified_name for node in nodes)

    def present(self) -> bool:
        """Any node or entity token."""
        with self.lock:
            return bool(self._nodes or self._entities)


def ros_domain_id(value: int | None) -> int:
    """The ROS domain: ``value``, else ``ROS_DOMAIN_ID``, else 0."""
    if value is None:
        text = os.environ.get('ROS_DOMAIN_ID', '').strip()
        if not text:
            return 0
        if not text.isdigit():
            raise ValueError(f'ROS_DOMAIN_ID must be a non-negative integer, not {text!r}')
        value = int(text)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f'a ROS domain id is a non-negative integer, not {value!r}')
    return value


class RmwZenohWire(Wire):
    """A node on a ROS 2 graph that runs rmw_zenoh, in one domain."""

    name = 'rmw_zenoh'
    token_view: ClassVar[type[TokenView]] = RmwZenohTokens
    type_conflict = (
        "rmw_zenoh puts the type and its hash in a topic's key, so the two keys never match "
        'and no message passes between them'
    )
    #: rmw_zenoh's own session settings: a peer that connects to the rmw_zenohd router and
    #: listens for peers on this machine, and rmw_zenoh's variables
    session: ClassVar[SessionDefaults] = SessionDefaults(
        mode='peer',
        connect='tcp/localhost:7447',
        peer_connects=True,
        listen='tcp/localhost:0',
        config_file_variable='ZENOH_SESSION_CONFIG_URI',
        override_variable='ZENOH_CONFIG_OVERRIDE',
    )

    def __init__(
        self,
        transport: Transport,
        namespace: str,
        node_name: str,
        registry: TypeRegistry,
        settings: Mapping[str, WireOption],
    ) -> None:
        super().__init__(transport, namespace, node_name, registry, settings)
        domain_id = settings.get('domain_id')
        if isinstance(domain_id, str):
            raise ValueError(f'a ROS domain id is a non-negative integer, not {domain_id!r}')
        humble = registry.distro == 'humble'  # Humble's rmw_zenoh writes no type hashes
        self.scheme: RmwZenohScheme = RmwZenohScheme(ros_domain_id(domain_id), humble=humble)
        self._ids = entity_ids(transport)
        #: the node's id and names, which its entities' tokens repeat
        self.node: NodeToken = self.scheme.node(transport.zid, self._ids(), namespace, node_name)

    @property
    def node_token(self) -> str:
        """The ``NN`` token that makes the node visible by name."""
        return self.node.format()

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
        """The key with type and hash, the token naming the node, and the token's GID."""
        hashed = None if self.scheme.humble else type_hash(registry, type_name)
        key = self.scheme.data_key(ros_name, type_name, hashed)
        token = self.scheme.token(
            kind, self.transport.zid, ros_name, type_name, qos=qos, type_hash=hashed,
            node=self.node, entity_id=self._ids(),
        )  # fmt: skip
        return RmwZenohEntity(key, (token,) if announce else (), gid(token))

    def unannounced(self, key: str) -> WireEntity:
        """An entity on ``key`` as is (it sends nothing: it has no GID)."""
        return RmwZenohEntity(key)

    def action_tokens(
        self, kind: EntityKind, ros_name: str, type_name: str, registry: TypeRegistry
    ) -> tuple[str, ...]:
        """None: rmw_zenoh has no action tokens."""
        return ()

    def announces_action_parts(self) -> bool:
        """Yes: an action is three services and two topics, each announced."""
        return True

    @staticmethod
    def any_type_key(key: str) -> str:
        """``<domain>/<name>/*/*``: any type and hash."""
        return key + '/*/*'
