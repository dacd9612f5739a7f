"""What every gateway (a WebSocket server that shows the ROS graph to browsers) shares.

* :class:`NameFilter`: allow and deny lists of names, as regular expressions (foxglove_bridge's
  whitelists) or globs (rosbridge's ``topics_glob``).
* :class:`GraphWatcher`: a thread that calls back when the graph changed (changes that come
  together are handled once).
* :class:`Taps`: a raw Zenoh subscription per watched topic, declared when the first watcher
  comes and released when the last leaves, with the QoS of the topic's publishers; the last
  messages of shallow latched (transient local) topics are kept for watchers that come later.
* :class:`SendQueue`: a client's bounded outbox that drops its oldest items and counts them.
* :class:`ClientCache`: the service and parameter clients made for clients, closed together;
  :func:`publisher_qos`: the QoS of a publisher a client asked for.

The graph views both gateways show are in :mod:`zros.gateway.views`, where they listen in
:mod:`zros.gateway.listen`.
"""

from __future__ import annotations

import collections
import fnmatch
import logging
import re
import threading
import time
from collections.abc import Callable, Hashable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, Protocol, TypeVar

from zros.gateway.errors import GatewayError as GatewayError  # noqa: PLC0414 (re-exported)
from zros.pubsub.taps import GraphTopic, RawTap, matched_qos
from zros.qos import Durability, QoS
from zros.runtime.signal import Signal

if TYPE_CHECKING:
    import zenoh

    from zros.graph import Graph
    from zros.node import Node
    from zros.node.settings import NodeSetting

_log = logging.getLogger('zros.gateway')

T = TypeVar('T')

#: seconds a graph watcher lets a burst of changes settle before looking
SETTLE = 0.05
#: seconds between a graph watcher's checks that it should stop
_POLL = 0.25
#: latched topics this deep or less keep their last messages for later watchers
REPLAY_DEPTH = 10


class NameFilter:
    """Which names pass: those matching an ``include`` pattern (every name when there is
    none) and no ``exclude`` pattern. Patterns match the whole name."""

    def __init__(
        self, include: Iterable[re.Pattern[str]] = (), exclude: Iterable[re.Pattern[str]] = ()
    ):
        self.include = list(include)
        self.exclude = list(exclude)

    @classmethod
    def regexes(
        cls, include: Iterable[str] | None = None, exclude: Iterable[str] | None = None
    ) -> NameFilter:
        """Python regular expressions, as foxglove_bridge's ``topic_whitelist`` (full match)."""

        def compile_all(patterns: Iterable[str] | None) -> list[re.Pattern[str]]:
            compiled = []
            for pattern in patterns or ():
                try:
                    compiled.append(re.compile(pattern))
                except re.error as exc:
                    raise GatewayError(
                        f'the pattern {pattern!r} is not a valid regex: {exc}'
                    ) from None
            return compiled

        return cls(compile_all(include), compile_all(exclude))

    @classmethod
    def globs(
        cls, include: Iterable[str] | None = None, exclude: Iterable[str] | None = None
    ) -> NameFilter:
        """Shell-style globs (``/camera/*``), as rosbridge's ``topics_glob``."""

        def compile_all(patterns: Iterable[str] | None) -> list[re.Pattern[str]]:
            return [re.compile(fnmatch.translate(p)) for p in patterns or ()]

        return cls(compile_all(include), compile_all(exclude))

    def __call__(self, name: str) -> bool:
        if self.include and not any(p.fullmatch(name) for p in self.include):
            return False
        return not any(p.fullmatch(name) for p in self.exclude)

    def __repr__(self) -> str:
        include = [p.pattern for p in self.include]
        return f'<NameFilter include={include} exclude={[p.pattern for p in self.exclude]}>'


class GraphWatcher:
    """Calls ``on_change()`` on a thread of its own once at the start and after every change
    of the node's graph (a burst of changes settles for ``settle`` seconds first). Exceptions
    of ``on_change`` are logged and the watcher goes on."""

    def __init__(self, node: Node, on_change: Callable[[], object], settle: float = SETTLE) -> None:
        self._graph: Graph = node.graph
        self._on_change = on_change
        self._settle = settle
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name='zros gateway graph', daemon=True)
        self._thread.start()

    def _run(self) -> None:
        graph = self._graph
        while not self._stopping.is_set():
            seen = graph.version
            try:
                self._on_change()
            except Exception:  # the graph thread outlives a bad graph entry or a closing session
                _log.exception('the gateway failed to follow the graph')
            changed = _changed_since(graph, seen)
            while not self._stopping.is_set() and not graph.wait_until(changed, _POLL):
                pass
            self._stopping.wait(self._settle)

    def close(self) -> None:
        """Stop watching (waits for a running ``on_change`` to finish)."""
        self._stopping.set()
        if threading.current_thread() is not self._thread:
            self._thread.join(5.0)


def _changed_since(graph: Graph, version: int) -> Callable[[], bool]:
    return lambda: graph.version != version


@dataclass
class _Tapped:
    name: str
    watchers: set[Hashable]
    latched: collections.deque[tuple[bytes, int]] | None
    tap: RawTap | None = None
    samples: int = 0
    bytes: int = 0
    failures: int = 0

    def close(self) -> None:
        if self.tap is not None:
            self.tap.close()


Deliver = Callable[[bytes, int], object]
#: ``limit(topic, deliver)``: the ``deliver`` a topic's messages go through (as
#: :meth:`zros.gateway.throttle.Throttle.limit`)
Limit = Callable[[str, Deliver], Deliver]


class Taps:
    """Raw subscriptions on the topics someone watches, and only on those.

    :meth:`watch` declares the Zenoh subscription on a topic when its first watcher comes,
    with the QoS matched to the topic's publishers (transient local when they all are: their
    latched messages arrive); ``deliver(data, time_ns)`` then gets every message's CDR bytes on
    the delivery thread (messages delivered together share one stamp). :meth:`unwatch`
    releases the subscription when the last watcher leaves, so unwatched topics carry no
    traffic. ``now()`` stamps the messages (ns).

    Latched topics of at most ``replay_depth`` messages (state: ``/tf_static``, a map, a robot
    description) keep their last messages for later watchers; deeper ones (history, such as
    ``/rosout``'s 1000) do not, since a gateway that cannot address one client would repeat
    them to every watcher.
    """

    def __init__(
        self,
        node: Node,
        now: Callable[[], int] = time.time_ns,
        replay_depth: int = REPLAY_DEPTH,
        limit: Limit | None = None,
    ) -> None:
        self._node = node
        #: what stands between a topic's messages and ``deliver`` (a rate limit), if anything
        self._limit = limit
        self._now = now
        self._replay_depth = replay_depth
        self._lock = threading.Lock()
        self._tapped: dict[str, _Tapped] = {}

    def watch(
        self, topic: GraphTopic, watcher: Hashable, deliver: Callable[[bytes, int], object]
    ) -> list[tuple[bytes, int]]:
        """Add ``watcher`` to ``topic``; returns the latched messages a new watcher of an
        already tapped latched topic would otherwise miss (empty otherwise)."""
        with self._lock:
            tapped = self._tapped.get(topic.name)
            if tapped is not None:
                tapped.watchers.add(watcher)
                return list(tapped.latched or ())
            qos = matched_qos(topic.offered)
            if self._limit is not None:
                deliver = self._limit(topic.name, deliver)
            kept = qos.transient_local and qos.depth <= self._replay_depth
            tapped = _Tapped(
                topic.name, {watcher}, collections.deque(maxlen=qos.depth) if kept else None
            )
            tapped.tap = RawTap(
                self._node,
                topic.name,
                topic.type_name,
                qos=qos,
                key=topic.key,
                batches=self._callback(tapped, deliver),
            )
            self._tapped[topic.name] = tapped
            _log.info('tapping %s [%s] (%s)', topic.name, topic.type_name, qos)
            return []

    def _callback(
        self, tapped: _Tapped, deliver: Callable[[bytes, int], object]
    ) -> Callable[[list[zenoh.Sample]], None]:
        now = self._now
        latched = tapped.latched

        def on_samples(samples: list[zenoh.Sample]) -> None:
            stamp = now()  # they were taken from Zenoh together
            for sample in samples:
                data = sample.payload.to_bytes()
                tapped.samples += 1
                tapped.bytes += len(data)
                if latched is not None:
                    latched.append((data, stamp))
                try:
                    deliver(data, stamp)
                except Exception:  # a broken client session: counted and logged
                    tapped.failures += 1
                    if tapped.failures == 1:  # a broken client must not flood the log
                        _log.exception(
                            'delivering a message of %s failed (logged once)', tapped.name
                        )

        return on_samples

    def unwatch(self, name: str, watcher: Hashable) -> None:
        """Remove ``watcher`` from the topic; the last one out releases the subscription."""
        with self._lock:
            tapped = self._tapped.get(name)
            if tapped is None:
                return
            tapped.watchers.discard(watcher)
            if tapped.watchers:
                return
            del self._tapped[name]
        tapped.close()
        _log.info('released %s', name)

    def drop(self, name: str) -> None:
        """Release a topic whatever its watchers (it left the graph)."""
        with self._lock:
            tapped = self._tapped.pop(name, None)
        if tapped is not None:
            tapped.close()

    def watched(self) -> dict[str, int]:
        """The tapped topics and how many watch each."""
        with self._lock:
            return {name: len(t.watchers) for name, t in self._tapped.items()}

    def counts(self, name: str) -> tuple[int, int]:
        """Messages and bytes received on a tapped topic so far ((0, 0) when not tapped)."""
        with self._lock:
            tapped = self._tapped.get(name)
            return (0, 0) if tapped is None else (tapped.samples, tapped.bytes)

    def close(self) -> None:
        """Release every subscription."""
        with self._lock:
            tapped, self._tapped = list(self._tapped.values()), {}
        for item in tapped:
            item.close()


class SendQueue(Generic[T]):
    """A client's outbox bounded in items and in bytes: a put that would pass either bound
    drops the oldest items first (counted in ``dropped``) and reports the drop once per burst
    through ``on_drop(dropped_so_far)``, so a slow client loses its stalest messages and is
    told, and never makes the sender wait."""

    def __init__(
        self,
        max_items: int = 1024,
        max_bytes: int = 10_000_000,
        on_drop: Callable[[int], object] | None = None,
    ) -> None:
        if max_items < 1 or max_bytes < 1:
            raise ValueError('a send queue holds at least one item and one byte')
        self.max_items = max_items
        self.max_bytes = max_bytes
        self._on_drop = on_drop
        self._items: collections.deque[tuple[T, int]] = collections.deque()
        self._bytes = 0
        self._lock = threading.Lock()
        self._arrived = Signal()
        self._dropping = False  #: inside a burst of drops (reported at its start)
        self._closed = False
        self.dropped = 0  #: items dropped so far

    def put(self, item: T, size: int) -> None:
        """Queue ``item`` of ``size`` bytes (an item larger than the byte bound goes alone)."""
        report = 0
        with self._lock:
            if self._closed:
                return
            items = self._items
            while items and (len(items) >= self.max_items or self._bytes + size > self.max_bytes):
                _, dropped_size = items.popleft()
                self._bytes -= dropped_size
                self.dropped += 1
                if not self._dropping:
                    self._dropping = True
                    report = self.dropped
            if not report and len(items) < self.max_items // 2:
                self._dropping = False
            items.append((item, size))
            self._bytes += size
        if report and self._on_drop is not None:
            try:
                self._on_drop(report)
            except Exception:  # a user callback: logged
                _log.exception('the drop callback %r raised', self._on_drop)
        if self._arrived:
            self._arrived.notify()

    def get(self, timeout: float | None = None) -> T | None:
        """The oldest item, waiting up to ``timeout`` seconds; None on timeout or when closed."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            with self._lock:
                if self._items:
                    item, size = self._items.popleft()
                    self._bytes -= size
                    return item
                if self._closed:
                    return None
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return None
            self._arrived.wait(lambda: bool(self._items) or self._closed, remaining)

    def __len__(self) -> int:
        return len(self._items)

    @property
    def size(self) -> int:
        """Bytes queued."""
        return self._bytes

    def close(self) -> None:
        """Drop what is queued and wake a waiting :meth:`get`."""
        with self._lock:
            self._closed = True
            self._items.clear()
            self._bytes = 0
        self._arrived.notify()


class Closable(Protocol):
    """What :class:`ClientCache` holds: anything with ``close()``."""

    def close(self) -> None: ...


C = TypeVar('C', bound=Closable)


class ClientCache(Generic[C]):
    """The service or parameter clients a gateway made, one per key, made on first use and
    closed together (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._clients: dict[Hashable, C] = {}

    def get(self, key: Hashable, make: Callable[[], C]) -> C:
        """The client of ``key``, made by ``make()`` the first time."""
        with self._lock:
            client = self._clients.get(key)
            if client is None:
                client = self._clients[key] = make()
            return client

    def discard(self, key: Hashable) -> None:
        """Close and forget the client of ``key`` (if any)."""
        with self._lock:
            client = self._clients.pop(key, None)
        if client is not None:
            client.close()

    def close(self) -> None:
        """Close every client."""
        with self._lock:
            clients, self._clients = list(self._clients.values()), {}
        for client in clients:
            client.close()


def gateway_node(name: str, settings: dict[str, NodeSetting]) -> Node:
    """A node of its own for a gateway, from the connection ``settings`` of :class:`zros.Node`
    (no /rosout and no parameter services unless asked)."""
    import zros

    settings.setdefault('enable_rosout', False)
    settings.setdefault('start_parameter_services', False)
    return zros.Node(name, **settings)


def publisher_qos(offered: Iterable[QoS], latched: bool = False) -> QoS:
    """The QoS of a publisher a client asked for: depth 1 transient local when it latches,
    else the QoS matched to the topic's other publishers (ROS 2's default without any)."""
    if latched:
        return QoS(1, durability=Durability.TRANSIENT_LOCAL)
    offers = list(offered)
    return matched_qos(offers) if offers else QoS()
