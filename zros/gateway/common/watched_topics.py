"""The raw subscriptions on the topics someone watches, shared by all of a gateway's clients.

:class:`Taps` declares a raw Zenoh subscription per watched topic when the first watcher comes
and releases it when the last leaves, with the QoS of the topic's publishers; the last messages
of shallow latched (transient local) topics are kept for watchers that come later.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from zros.pubsub.taps import GraphTopic, RawTap, matched_qos

if TYPE_CHECKING:
    import zenoh

    from zros.node import Node

_log = logging.getLogger('zros.gateway')

#: latched topics this deep or less keep their last messages for later watchers
REPLAY_DEPTH = 10


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
#: :meth:`zros.gateway.common.throttle.Throttle.limit`)
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
