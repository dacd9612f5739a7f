"""What the runtime does per wire scheme: entity keys, tokens and GIDs, and rmw_zenoh attachments.

A node holds a scheme (``BridgeScheme`` or ``RmwZenohScheme``); publishers, subscribers,
services and actions ask :func:`entity_wire` for their key and tokens. Through a bridge an entity
has two tokens (the bridge's ``@ros2_lv`` form and zros's ``@zros_lv`` owner link); under
rmw_zenoh one token whose XXH3 is the entity's GID, which goes into the attachment of every
publication, request and reply (:class:`Sequence`, :class:`Requests`).
"""

from __future__ import annotations

import itertools
import logging
import struct
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from zros.keyexpr.attachment import GID_SIZE, SIZE, Attachment, AttachmentError
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.rmw_zenoh import RmwZenohScheme, gid
from zros.qos import QoS

if TYPE_CHECKING:
    from zros.cdr import TypeRegistry
    from zros.node import Node

_log = logging.getLogger('zros')

WIRES = ('bridge', 'rmw_zenoh')


def check_wire(wire: str) -> str:
    """``wire`` if it names a scheme zros speaks, else ValueError."""
    if wire not in WIRES:
        raise ValueError(f'wire must be "bridge" or "rmw_zenoh", got {wire!r}')
    return wire


@dataclass(frozen=True)
class EntityWire:
    """Where one entity lives on the wire."""

    key: str  #: the Zenoh key to declare on
    tokens: tuple[str, ...]  #: liveliness tokens announcing it, declared in order
    gid: bytes | None  #: rmw_zenoh: the GID sent in its attachments


def entity_wire(
    node: Node,
    kind: EntityKind,
    ros_name: str,
    type_name: str,
    registry: TypeRegistry,
    *,
    qos: QoS | None = None,
    announce: bool = True,
) -> EntityWire:
    """The key, tokens and GID of an entity of ``node`` (ids drawn from the session's counter)."""
    scheme = node.scheme
    type_hash = None
    if scheme.send_type_hash and not getattr(scheme, 'humble', False):
        from zros.cdr.hashing import type_hash as compute

        type_hash = compute(registry, type_name)
    key = scheme.data_key(ros_name, type_name, type_hash)
    transport = node.transport
    if isinstance(scheme, RmwZenohScheme):
        token = scheme.token(
            kind, transport.zid, ros_name, type_name, qos=qos, type_hash=type_hash,
            node=node._wire_node, entity_id=transport.next_entity_id(),
        )  # fmt: skip
        return EntityWire(key, (token,) if announce else (), gid(token))
    if not announce:
        return EntityWire(key, (), None)
    from zros.keyexpr.owners import entity_token

    owner = entity_token(transport.zid, node.fully_qualified_name, kind, key, type_name)
    token = scheme.token(
        kind, transport.zid, ros_name, type_name, qos=qos if kind.has_qos else None,
        type_hash=type_hash,
    )  # fmt: skip
    return EntityWire(key, (owner, token), None)


def has_attachment(carrier: Any) -> bool:
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


def read_attachment(carrier: Any) -> Attachment | None:
    """The rmw_zenoh attachment of a sample, query or reply; None if absent or malformed."""
    raw = carrier.attachment
    if raw is None:
        return None
    try:
        return Attachment.decode(raw.to_bytes())
    except AttachmentError:
        return None


class Sequence:
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


class Requests:
    """The queries a server holds: admitted by rmw_zenoh's rules, answered exactly once.

    Without attachments (the bridge) every query is admitted and replies carry none. With them,
    a query needs a valid attachment with a non-negative sequence number and timestamp, and no
    pending query of the same client may have the same number; replies echo the number and the
    client's GID with a fresh timestamp.
    """

    def __init__(self, attachments: bool, name: str, error_prefix: str) -> None:
        self.attachments = attachments
        self.name = name
        self.error_prefix = error_prefix
        self._pending: dict[int, tuple[bytes, int]] = {}  # id(query) -> (client GID, seq)
        self._keys: set[tuple[bytes, int]] = set()
        self._lock = threading.Lock()
        self._warned = False

    def admit(self, query: Any) -> bool:
        """Whether to handle ``query``; refused ones got their error reply already."""
        if not self.attachments:
            return True
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
        self._finish(query, lambda: query.reply_err(self.error_prefix + reason))
        return False

    def _finish(self, query: Any, answer: Any) -> None:
        with self._lock:
            key = self._pending.pop(id(query), None)
            if key is not None:
                self._keys.discard(key)
        try:
            answer()
        finally:
            query.drop()

    def reply(self, query: Any, payload: bytes | bytearray) -> None:
        """Send the reply (with the echoed attachment under rmw_zenoh) and end the query."""
        attachment = None
        if self.attachments:
            request = read_attachment(query)
            if request is not None:
                attachment = Attachment(
                    request.sequence_number, time.time_ns(), request.gid
                ).encode()
        self._finish(query, lambda: query.reply(query.key_expr, payload, attachment=attachment))

    def fail(self, query: Any, reason: str) -> None:
        """Send an error reply (``error_prefix`` + reason) and end the query."""
        self._finish(query, lambda: query.reply_err(self.error_prefix + reason))


def attachment_of_reply(reply: Any, sent: bytes) -> str | None:
    """Why a service reply does not answer the request whose attachment was ``sent``; None when
    its attachment echoes the request's sequence number."""
    attachment = read_attachment(reply)
    if attachment is None:
        return 'its reply carries no valid rmw_zenoh attachment'
    expected = Attachment.decode(sent).sequence_number
    if attachment.sequence_number != expected:
        return f'its reply answers request {attachment.sequence_number}, not request {expected}'
    return None
