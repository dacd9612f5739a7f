"""Topics for rosbridge clients: ``subscribe``/``unsubscribe`` and ``advertise``/``publish``.

A topic someone subscribes to gets one raw Zenoh tap
(:class:`~zros.gateway.common.watched_topics.Taps`, with the QoS of its publishers) whatever the
number of clients; each sample is wrapped once in a :class:`~zros.gateway.rosbridge.frames.Sample`
and offered to every subscription, which puts it into its client's bounded outbox as the client
asked: at most one message per ``throttle_rate`` ms, the newest ``queue_length`` held meanwhile
(oldest dropped), in its ``compression``, cut into ``fragment_size`` fragments. Several
``subscribe`` messages of one client for one topic make one subscription with the lowest throttle
rate and fragment size, the shortest queue and the heaviest compression, as rosbridge merges them.

Publishing goes through one zros publisher per topic, shared by the clients that advertise
it (latched when asked: transient local, depth 1).

A client holds at most :data:`MAX_TOPICS` subscriptions and as many advertised topics, and
:data:`MAX_REQUESTS` subscribe requests of one topic: each tap is a Zenoh subscription with a
thread of its own, each publisher shows in the whole graph, and names cost nothing to invent.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from collections.abc import Hashable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from zros.errors import ZrosError
from zros.gateway.common.counts import count_down
from zros.gateway.common.entities import publisher_qos
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.common.json_types import int_field, optional_text, text_field
from zros.gateway.common.watched_topics import Taps
from zros.gateway.rosbridge.conversion import ConversionError, Values
from zros.gateway.rosbridge.frames import COMPRESSIONS, Frames, Sample
from zros.pubsub.taps import GraphTopic, graph_topics

if TYPE_CHECKING:
    from zros.cdr import JsonValue, Message
    from zros.gateway.common.json_types import JsonObject, OutObject
    from zros.node import Node
    from zros.pubsub import Publisher

_log = logging.getLogger('zros.gateway')

#: topics one client may subscribe to at once, and topics it may advertise at once
MAX_TOPICS = 1000
#: subscribe requests (ids) one client may hold for one topic (they are merged per message)
MAX_REQUESTS = 100


class Peer(Protocol):
    """What the topics, calls and rosapi need of a connected client."""

    id: int

    def send(
        self, message: OutObject, compression: str = 'none', fragment_size: int = 0
    ) -> None: ...

    def send_frames(self, frames: Frames) -> None: ...

    def status(self, level: str, text: str, op_id: JsonValue = None) -> None: ...


@dataclass(frozen=True)
class _Request:
    throttle_rate: int = 0  #: ms
    queue_length: int = 0
    fragment_size: int = 0  #: 0: none
    compression: str = 'none'


class Subscription:
    """One client's subscription to one topic (its subscribe requests merged)."""

    def __init__(self, peer: Peer, topic: str, type_name: str, pacer: Pacer) -> None:
        self.peer = peer
        self.topic = topic
        self.type_name = type_name
        self._pacer = pacer
        self.requests: dict[JsonValue, _Request] = {}
        self.throttle = 0.0  #: seconds
        self.queue_length = 0
        self.fragment_size = 0
        self.compression = 'none'
        self._last = -float('inf')
        self.held: collections.deque[Sample] = collections.deque()
        self._failed = False

    def update(self) -> None:
        """Merge the requests as rosbridge does."""
        requests = list(self.requests.values())
        self.throttle = min(r.throttle_rate for r in requests) / 1000.0
        self.queue_length = min(r.queue_length for r in requests)
        sizes = [r.fragment_size for r in requests if r.fragment_size > 0]
        self.fragment_size = min(sizes, default=0)
        chosen = {r.compression for r in requests}
        self.compression = next(c for c in reversed(COMPRESSIONS) if c in chosen or c == 'none')
        self.held = collections.deque(self.held, maxlen=self.queue_length or None)

    def offer(self, sample: Sample) -> None:
        """A message arrived (on Zenoh's thread): send it, hold it or drop it."""
        if self.throttle <= 0:
            self._send(sample)
        elif self.queue_length <= 0:
            now = time.monotonic()
            if now - self._last >= self.throttle:
                self._last = now
                self._send(sample)
        else:
            self.held.append(sample)
            self._pacer.add(self)

    def release(self, now: float) -> float | None:
        """Send the oldest held message if its time has come; seconds until the next is due
        (None when nothing is held)."""
        if not self.held:
            return None
        wait = self._last + self.throttle - now
        if wait > 0:
            return wait
        try:
            sample = self.held.popleft()
        except IndexError:
            return None
        self._last = now
        self._send(sample)
        return self.throttle if self.held else None

    def _send(self, sample: Sample) -> None:
        try:
            frames = sample.frames(self.compression, self.fragment_size)
        except (ZrosError, ValueError) as exc:
            if not self._failed:  # once per subscription: a topic may carry thousands
                self._failed = True
                self.peer.status('error', f'a message of {self.topic} cannot be sent: {exc}')
            return
        self.peer.send_frames(frames)


class Pacer:
    """Releases the held messages of throttled subscriptions when due (one thread)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._waiting: set[Subscription] = set()
        self._wake = threading.Event()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name='zros rosbridge pacer', daemon=True)
        self._thread.start()

    def add(self, subscription: Subscription) -> None:
        """``subscription`` holds messages."""
        with self._lock:
            if subscription not in self._waiting:
                self._waiting.add(subscription)
                self._wake.set()

    def _run(self) -> None:
        while not self._closed:
            with self._lock:
                waiting = list(self._waiting)
            waits = []
            for subscription in waiting:
                wait = subscription.release(time.monotonic())
                if wait is not None:
                    waits.append(wait)
                    continue
                with self._lock:
                    if not subscription.held:
                        self._waiting.discard(subscription)
            self._wake.wait(min(waits, default=None))
            self._wake.clear()

    def discard(self, subscription: Subscription) -> None:
        """Forget a subscription that ended."""
        with self._lock:
            self._waiting.discard(subscription)

    def close(self) -> None:
        """Stop the thread."""
        self._closed = True
        self._wake.set()
        self._thread.join(5.0)


class _Stream:
    """One tapped topic and the subscriptions it feeds."""

    def __init__(self, topic: GraphTopic, cls: type[Message], values: Values) -> None:
        self.topic = topic
        self.cls = cls
        self.values = values
        self.subscriptions: tuple[Subscription, ...] = ()

    def sample(self, data: bytes, stamp: int) -> Sample:
        return Sample(self.topic.name, self.cls, data, stamp, self.values)

    def deliver(self, data: bytes, stamp: int) -> None:
        sample = self.sample(data, stamp)
        for subscription in self.subscriptions:
            subscription.offer(sample)


class Topics:
    """The subscriptions and publishers of every client of one gateway."""

    def __init__(self, node: Node, values: Values, allowed: NameFilter, taps: Taps) -> None:
        self._node = node
        self._values = values
        self._allowed = allowed
        self._taps = taps
        self._pacer = Pacer()
        self._lock = threading.Lock()
        self._streams: dict[str, _Stream] = {}
        self._subscriptions: dict[tuple[int, str], Subscription] = {}
        self._publishers: dict[str, _Published] = {}
        # per client: how many topics it subscribes to, and advertises
        self._subscribed: collections.Counter[int] = collections.Counter()
        self._advertised: collections.Counter[int] = collections.Counter()

    # --- names and types ---------------------------------------------------------------------

    def _name(self, topic: str) -> str:
        try:
            name = self._node.resolve_name(topic)
        except (ZrosError, ValueError) as exc:
            raise GatewayError(f'{topic!r} is not a valid topic name: {exc}') from None
        if not self._allowed(name):
            raise GatewayError(f'{name} is not allowed here (topics glob)')
        return name

    def _graph_topic(self, name: str) -> GraphTopic | None:
        found = graph_topics(self._node, publishers_only=False).get(name)
        if found is None:  # a client's publisher the graph may not show yet
            published = self._publishers.get(name)
            if published is not None:
                return GraphTopic(name, published.publisher.type_name)
        return found

    def _type(self, name: str, asked: str | None, known: GraphTopic | None) -> str:
        """The topic's type: the graph's, checked against ``asked``."""
        if asked is None:
            if known is None:
                raise GatewayError(
                    f'Cannot infer topic type for topic {name} as it is not yet advertised'
                )
            return known.type_name
        try:
            type_name = self._node.registry.get_class(asked).__msgtype__
        except ZrosError as exc:
            raise GatewayError(f'unknown type {asked}: {exc}') from None
        if known is not None and known.type_name != type_name:
            raise GatewayError(
                f'Tried to register topic {name} with type {type_name} but it is '
                f'already established with type {known.type_name}'
            )
        return type_name

    # --- subscribing -------------------------------------------------------------------------

    def subscribe(self, peer: Peer, op: JsonObject) -> None:
        """A ``subscribe`` message (GatewayError says why it was refused)."""
        name = self._name(text_field(op, 'topic'))
        request = _Request(
            int_field(op, 'throttle_rate'),
            int_field(op, 'queue_length'),
            int_field(op, 'fragment_size'),
            optional_text(op, 'compression') or 'none',
        )
        if request.compression not in COMPRESSIONS:
            raise GatewayError(f'unknown compression {request.compression!r}: {COMPRESSIONS}')
        if min(request.throttle_rate, request.queue_length, request.fragment_size) < 0:
            raise GatewayError('throttle_rate, queue_length and fragment_size are never negative')
        with self._lock:  # before the graph is looked at: refusing costs next to nothing
            self._check_room(peer.id, name)
        known = self._graph_topic(name)
        with self._lock:
            subscription = self._subscriptions.get((peer.id, name))
            if subscription is not None:
                self._type(
                    name, optional_text(op, 'type'), GraphTopic(name, subscription.type_name)
                )
                requests = subscription.requests
                if op.get('id') not in requests and len(requests) >= MAX_REQUESTS:
                    raise GatewayError(
                        f'a client may hold at most {MAX_REQUESTS} subscribe requests of one '
                        f'topic ({name}): unsubscribe one first'
                    )
            else:
                self._check_room(peer.id, name)
                type_name = self._type(name, optional_text(op, 'type'), known)
                subscription = Subscription(peer, name, type_name, self._pacer)
            subscription.requests[op.get('id')] = request
            subscription.update()
            if (peer.id, name) in self._subscriptions:
                return
            self._subscriptions[peer.id, name] = subscription
            self._subscribed[peer.id] += 1
            stream = self._streams.get(name)
            if stream is None:
                cls = self._node.registry.get_class(subscription.type_name)
                stream = _Stream(known or GraphTopic(name, cls.__msgtype__), cls, self._values)
                self._streams[name] = stream
            stream.subscriptions = (*stream.subscriptions, subscription)
            latched = self._taps.watch(stream.topic, subscription, stream.deliver)
        for data, stamp in latched:  # a latched topic others watch already: this one's copy
            subscription.offer(stream.sample(data, stamp))

    def _check_room(self, peer: int, name: str) -> None:
        """GatewayError if client ``peer`` may not subscribe to one more topic (under the
        lock)."""
        if (peer, name) not in self._subscriptions and self._subscribed[peer] >= MAX_TOPICS:
            raise GatewayError(
                f'a client may subscribe to at most {MAX_TOPICS} topics at once: '
                'unsubscribe one first'
            )

    def unsubscribe(self, peer: Peer, op: JsonObject) -> None:
        """An ``unsubscribe`` message: its id's request ends, or all of the client's for the
        topic without an id."""
        name = self._name(text_field(op, 'topic'))
        with self._lock:
            subscription = self._subscriptions.get((peer.id, name))
            if subscription is None:
                return
            sid = op.get('id')
            if sid is None or sid not in subscription.requests:
                subscription.requests.clear()
            else:
                del subscription.requests[sid]
            if subscription.requests:
                subscription.update()
                return
        self._end(subscription)

    def _end(self, subscription: Subscription) -> None:
        with self._lock:
            if self._subscriptions.pop((subscription.peer.id, subscription.topic), None) is None:
                return
            count_down(self._subscribed, subscription.peer.id)
            stream = self._streams[subscription.topic]
            stream.subscriptions = tuple(s for s in stream.subscriptions if s is not subscription)
            if not stream.subscriptions:
                del self._streams[subscription.topic]
            self._taps.unwatch(subscription.topic, subscription)
        self._pacer.discard(subscription)

    def subscribed(self, peer: Hashable) -> dict[str, Subscription]:
        """A client's subscriptions by topic."""
        with self._lock:
            return {t: s for (p, t), s in self._subscriptions.items() if p == peer}

    # --- publishing --------------------------------------------------------------------------

    def advertise(self, peer: Peer, op: JsonObject) -> None:
        """An ``advertise`` message: the topic's publisher exists and counts the client."""
        name = self._name(text_field(op, 'topic'))
        self._publisher(peer, name, text_field(op, 'type'), bool(op.get('latch')))

    def _publisher(self, peer: Peer, name: str, asked: str | None, latch: bool) -> _Published:
        with self._lock:
            published = self._publishers.get(name)
            joins = published is None or peer.id not in published.peers
            if joins and self._advertised[peer.id] >= MAX_TOPICS:
                raise GatewayError(
                    f'a client may advertise at most {MAX_TOPICS} topics at once: '
                    'unadvertise one first'
                )
            if published is None:
                known = self._graph_topic(name)
                type_name = self._type(name, asked, known)
                offered = known.offered if known is not None else []
                try:
                    publisher = self._node.create_publisher(
                        type_name, name, publisher_qos(offered, latch)
                    )
                except (ZrosError, ValueError) as exc:
                    raise GatewayError(f'cannot publish on {name}: {exc}') from None
                published = self._publishers[name] = _Published(publisher, set())
            elif asked is not None:
                self._type(name, asked, GraphTopic(name, published.publisher.type_name))
            if joins:
                published.peers.add(peer.id)
                self._advertised[peer.id] += 1
            return published

    def unadvertise(self, peer: Peer, op: JsonObject) -> None:
        """An ``unadvertise`` message: the last client out closes the publisher."""
        name = self._name(text_field(op, 'topic'))
        self._release(peer.id, name)

    def _release(self, peer: int, name: str) -> None:
        with self._lock:
            published = self._publishers.get(name)
            if published is None or peer not in published.peers:
                return
            published.peers.discard(peer)
            count_down(self._advertised, peer)
            if published.peers:
                return
            del self._publishers[name]
        published.publisher.close()

    def publish(self, peer: Peer, op: JsonObject) -> None:
        """A ``publish`` message (the topic is advertised on the way if it was not)."""
        name = self._name(text_field(op, 'topic'))
        published = self._publisher(peer, name, None, bool(op.get('latch')))
        cls = published.publisher.msg_type
        try:
            message = self._values.from_json(cls, op.get('msg', {}))
        except ConversionError as exc:
            raise GatewayError(str(exc)) from None
        published.publisher.write(message)

    # --- lifetime ----------------------------------------------------------------------------

    def drop(self, peer: int) -> None:
        """A client left: end its subscriptions and release its publishers."""
        for subscription in self.subscribed(peer).values():
            self._end(subscription)
        with self._lock:
            names = [n for n, p in self._publishers.items() if peer in p.peers]
        for name in names:
            self._release(peer, name)

    def close(self) -> None:
        """Stop sending and close every publisher."""
        self._pacer.close()
        with self._lock:
            published, self._publishers = list(self._publishers.values()), {}
            self._streams.clear()
            self._subscriptions.clear()
            self._subscribed.clear()
            self._advertised.clear()
        for item in published:
            item.publisher.close()


@dataclass
class _Published:
    publisher: Publisher[Message]
    peers: set[int]
