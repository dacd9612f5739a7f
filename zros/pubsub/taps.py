"""Raw taps: Zenoh subscriptions on a topic that hand over the CDR bytes and never decode.

What the recorder and the gateways share: which topics the graph shows (grouped by name, with
the publishers' QoS and key), the QoS to subscribe with (adapted to the publishers as rosbag2
adapts it: transient local only when every publisher is), and :class:`RawTap`, a subscription
announced in the graph like a zros subscriber whose callback runs on Zenoh's thread with the
raw sample.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from zenoh import Sample

from zros.errors import ZrosError
from zros.graph import Endpoint, graph_of
from zros.keyexpr.kinds import EntityKind
from zros.qos import Durability, History, QoS, Reliability
from zros.runtime.defaults import NodeLike
from zros.runtime.entity import Entity
from zros.wire import any_type_key, read_attachment

if TYPE_CHECKING:
    from zros.wire import WireEntity

_log = logging.getLogger('zros')


def is_hidden(name: str) -> bool:
    """Whether a topic is hidden (a name part starts with ``_``), as ROS 2 tools hide them."""
    return any(part.startswith('_') for part in name.split('/'))


def matched_qos(offered: Iterable[QoS]) -> QoS:
    """The QoS to subscribe to publishers with, adapted as rosbag2 adapts it: reliable and
    transient local only when every publisher is, deep enough for the deepest one."""
    offers = list(offered)
    reliable = all(q.reliable for q in offers)
    latched = bool(offers) and all(q.transient_local for q in offers)
    depth = max((q.depth for q in offers), default=10)
    return QoS(
        max(depth, 1),
        Reliability.RELIABLE if reliable else Reliability.BEST_EFFORT,
        Durability.TRANSIENT_LOCAL if latched else Durability.VOLATILE,
        History.KEEP_LAST,
    )


def publish_time(sample: Sample, fallback: int) -> int:
    """When a sample was published, in nanoseconds: the time in its rmw_zenoh attachment, else
    its Zenoh timestamp (set by the publishing session), else ``fallback``."""
    if sample.attachment is not None:
        attachment = read_attachment(sample)
        if attachment is not None:
            return int(attachment.source_timestamp)
    stamp = sample.timestamp
    if stamp is None:
        return fallback
    try:
        return int(stamp.get_time_as_ntp64().as_nanos())
    except (AttributeError, ValueError, OverflowError):  # an old zenoh, or a bad stamp
        return fallback


@dataclass(frozen=True)
class GraphTopic:
    """A topic as the graph shows it: its type, who publishes and subscribes, and the key its
    publishers put on."""

    name: str
    type_name: str
    publishers: list[Endpoint] = field(default_factory=list)
    subscribers: list[Endpoint] = field(default_factory=list)

    @property
    def offered(self) -> list[QoS]:
        """The QoS profiles its publishers offer."""
        return [e.qos for e in self.publishers if e.qos is not None]

    @property
    def key(self) -> str | None:
        """The key to subscribe to when the node cannot make it (an unknown type): the
        publishers' (under rmw_zenoh with wildcards for the type and hash chunks)."""
        for endpoint in self.publishers or self.subscribers:
            return any_type_key(endpoint.wire, endpoint.key)
        return None


def graph_topics(
    node: NodeLike, *, publishers_only: bool = True, exclude_node: str | None = None
) -> dict[str, GraphTopic]:
    """The topics of the graph by name (with publishers, or with any endpoint), leaving out the
    endpoints of the node named ``exclude_node``. A name announced with several types keeps the
    first, with a warning."""
    kinds = (
        (EntityKind.PUBLISHER,)
        if publishers_only
        else (EntityKind.PUBLISHER, EntityKind.SUBSCRIBER)
    )
    context = node.context
    namespace = context.wire.namespace
    by_name: dict[str, list[Endpoint]] = {}
    for endpoint in graph_of(context.transport).endpoints(kinds):
        if exclude_node is not None and endpoint.node == exclude_node:
            continue
        by_name.setdefault(endpoint.ros_name(namespace), []).append(endpoint)
    topics = {}
    for name, endpoints in sorted(by_name.items()):
        types = sorted({e.type_name for e in endpoints})
        if len(types) > 1:
            _log.warning('topic %s has several types %s: using %s', name, types, types[0])
        chosen = [e for e in endpoints if e.type_name == types[0]]
        topics[name] = GraphTopic(
            name,
            types[0],
            [e for e in chosen if e.kind is EntityKind.PUBLISHER],
            [e for e in chosen if e.kind is EntityKind.SUBSCRIBER],
        )
    return topics


class RawTap(Entity):
    """A raw Zenoh subscription on one topic, announced in the graph like a zros subscriber;
    ``callback(sample)`` runs on the delivery thread (Zenoh's for transient local) with each
    sample the node's wire accepts, undecoded (or ``batches(samples)`` with several at once,
    oldest first).

    ``key`` (matching the publishers' keys) is used when the node cannot make the topic's key
    and tokens itself (a type it does not know), or with ``announce`` False: the topic is then
    tapped unannounced.
    Transient-local taps fetch what the publishers' caches hold (latched messages).
    """

    def __init__(
        self,
        node: NodeLike,
        topic: str,
        type_name: str,
        *,
        qos: QoS,
        key: str | None,
        callback: Callable[[Sample], None] | None = None,
        batches: Callable[[list[Sample]], None] | None = None,
        announce: bool = True,
    ) -> None:
        if (callback is None) == (batches is None):
            raise TypeError('a RawTap takes a callback or batches, not both')
        super().__init__(node)
        self.topic = topic
        self.qos = qos
        context = self.context
        self.transport = context.transport
        wire: WireEntity | None = None
        if announce:
            try:
                wire = self._place(
                    EntityKind.SUBSCRIBER, topic, type_name, context.registry, qos=qos
                )
            except ZrosError as exc:
                if key is None:
                    raise
                _log.debug('not announcing the tap on %s: %s', topic, exc)
        if wire is None:
            if key is None:
                raise TypeError('an unannounced RawTap needs the key to tap')
            wire = context.wire.unannounced(key)
        self.key = wire.key
        self._subscribe(wire, qos, callback, batches=batches)
        self._announce()

    def __repr__(self) -> str:
        return f'<zros RawTap {self.topic} on {self.key} {self.qos}>'
