"""message_filters for live nodes, with rclpy's names: subscribers whose messages go through
a cache or a synchronizer to your callback.

>>> from zros.message_filters import Subscriber, ApproximateTimeSynchronizer
>>> imu = Subscriber(node, 'sensor_msgs/msg/Imu', '/imu')            # doctest: +SKIP
>>> odom = Subscriber(node, 'nav_msgs/msg/Odometry', '/odom')        # doctest: +SKIP
>>> sync = ApproximateTimeSynchronizer([imu, odom], 10, 0.05)        # doctest: +SKIP
>>> sync.registerCallback(lambda i, o: print(i.header.stamp, o.header.stamp))  # doctest: +SKIP

Callbacks run where the node's other callbacks run (when it spins, or at once on an immediate
executor): a :class:`Subscriber` is a node subscription whose callback feeds the filters. The
synchronizers match as rclpy's do (:mod:`zros.timesync`); ``Bag.synchronize`` matches a
recording's messages by the same rules. Messages without ``header.stamp`` are dropped with a
warning, unless ``allow_headerless``: then they are stamped with the node's clock on arrival.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from zros.runtime.clock import Time
from zros.timesync import ApproximatePolicy, ExactPolicy, header_stamp

if TYPE_CHECKING:
    from zros.cdr import Message
    from zros.node import Node
    from zros.pubsub.subscriber import Subscriber as NodeSubscriber
    from zros.qos import QoSLike

_log = logging.getLogger('zros.message_filters')
_NS = 1_000_000_000

#: a filter's callback: the filter's output, then the arguments it was registered with
Callback = Callable[..., object]  # type: ignore[explicit-any,unused-ignore]  # any signature, as in rclpy


#: a time: integer nanoseconds or a ``zros.Time``
Stamp = int | Time


def _ns(value: Stamp) -> int:
    if isinstance(value, Time):
        return value.nanoseconds
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(
            f'a stamp is integer nanoseconds or a zros.Time, not {type(value).__name__}'
        )
    return value


class SimpleFilter:
    """A filter: it hands its output to the callbacks registered on it, in their order."""

    def __init__(self) -> None:
        self.callbacks: dict[int, tuple[Callback, tuple[object, ...]]] = {}

    def registerCallback(self, cb: Callback, *args: object) -> int:  # noqa: N802 (rclpy's name)
        """Call ``cb(*output, *args)`` for each output of this filter; returns its key."""
        key = len(self.callbacks)
        self.callbacks[key] = (cb, args)
        return key

    register_callback = registerCallback

    def signalMessage(self, *messages: object) -> None:  # noqa: N802 (rclpy's name)
        """Hand ``messages`` to every registered callback."""
        for cb, args in list(self.callbacks.values()):
            cb(*messages, *args)

    signal_message = signalMessage


class Subscriber(SimpleFilter):
    """A node subscription as the first filter of a chain (rclpy's ``message_filters.Subscriber``).

    ``qos_profile`` is a depth or a ``zros.QoS`` (default: keep last 10, as rclpy's).
    """

    def __init__(
        self,
        node: Node,
        msg_type: str | type[Message],
        topic: str,
        qos_profile: QoSLike = 10,
    ) -> None:
        super().__init__()
        self.node = node
        self.topic = topic
        self.sub: NodeSubscriber = node.create_subscription(
            msg_type, topic, self.callback, qos=qos_profile
        )

    def callback(self, msg: Message) -> None:
        """The subscription's callback: hands ``msg`` on."""
        self.signalMessage(msg)

    def getTopic(self) -> str:  # noqa: N802 (rclpy's name)
        """The topic name given."""
        return self.topic

    def close(self) -> None:
        """Close the subscription."""
        self.sub.close()


def _clock_of(filters: Sequence[object]) -> Callable[[], int]:
    """The node clock of the first input that has a node, else the system clock (ns)."""
    for f in filters:
        node = getattr(f, 'node', None)
        if node is not None:
            clock = node.get_clock()
            return lambda: int(clock.now().nanoseconds)
    return time.time_ns


def _stamp_or_warn(
    msg: object, allow_headerless: bool, now: Callable[[], int], who: str, warned: set[str]
) -> int | None:
    stamp = header_stamp(msg)
    if stamp is not None:
        return stamp
    if allow_headerless:
        return now()
    kind = type(msg).__name__
    if kind not in warned:  # once per type: a headerless topic would warn at its rate
        warned.add(kind)
        _log.warning(
            '%s drops every %s: it has no header.stamp (allow_headerless=True stamps such '
            'messages with the time they arrive)',
            who,
            kind,
        )
    return None


class Cache(SimpleFilter):
    """The newest ``cache_size`` messages of a filter, by header stamp; it hands each on."""

    def __init__(
        self, f: SimpleFilter, cache_size: int = 1, allow_headerless: bool = False
    ) -> None:
        super().__init__()
        if cache_size < 1:
            raise ValueError(f'cache_size must be at least 1, got {cache_size}')
        self.cache_size = cache_size
        self.allow_headerless = allow_headerless
        self.cache_msgs: list[object] = []
        self.cache_times: list[int] = []  #: stamps in ns, in arrival order
        self._now = _clock_of([f])
        self._warned: set[str] = set()
        self._lock = threading.Lock()
        self.incoming_connection = f.registerCallback(self.add)

    def add(self, msg: object) -> None:
        """Keep ``msg`` (dropping the oldest past ``cache_size``) and hand it on."""
        stamp = _stamp_or_warn(msg, self.allow_headerless, self._now, 'Cache', self._warned)
        if stamp is None:
            return
        with self._lock:
            self.cache_msgs.append(msg)
            self.cache_times.append(stamp)
            if len(self.cache_msgs) > self.cache_size:
                del self.cache_msgs[0], self.cache_times[0]
        self.signalMessage(msg)

    def _pairs(self) -> list[tuple[object, int]]:
        with self._lock:
            return list(zip(self.cache_msgs, self.cache_times, strict=True))

    def getInterval(self, from_stamp: Stamp, to_stamp: Stamp) -> list[object]:  # noqa: N802
        """The cached messages stamped from ``from_stamp`` to ``to_stamp`` (inclusive)."""
        start, end = _ns(from_stamp), _ns(to_stamp)
        if start > end:
            raise ValueError(f'the interval starts after it ends: {start} > {end} ns')
        return [m for m, t in self._pairs() if start <= t <= end]

    def getElemAfterTime(self, stamp: Stamp) -> object | None:  # noqa: N802
        """The oldest cached message stamped at or after ``stamp``, or None."""
        at = _ns(stamp)
        return next((m for m, t in self._pairs() if t >= at), None)

    def getElemBeforeTime(self, stamp: Stamp) -> object | None:  # noqa: N802
        """The newest cached message stamped at or before ``stamp``, or None."""
        at = _ns(stamp)
        older = [m for m, t in self._pairs() if t <= at]
        return older[-1] if older else None

    def getLatestTime(self) -> Time | None:  # noqa: N802
        """The stamp of the newest cached message, or None."""
        pairs = self._pairs()
        return Time(pairs[-1][1]) if pairs else None

    getLastestTime = getLatestTime  # noqa: N815 (rclpy's spelling)

    def getOldestTime(self) -> Time | None:  # noqa: N802
        """The stamp of the oldest cached message, or None."""
        pairs = self._pairs()
        return Time(pairs[0][1]) if pairs else None

    def getLast(self) -> object | None:  # noqa: N802
        """The newest cached message, or None."""
        pairs = self._pairs()
        return pairs[-1][0] if pairs else None


class TimeSynchronizer(SimpleFilter):
    """Calls back with one message per input when all carry the same header stamp.

    ``queue_size`` is how many stamps each input keeps while waiting for the others.
    """

    allow_headerless = False

    def __init__(self, fs: Sequence[SimpleFilter], queue_size: int) -> None:
        super().__init__()
        self.queue_size = queue_size
        self._policy = self._make_policy(len(fs))
        self._now = _clock_of(fs)
        self._warned: set[str] = set()
        self._lock = threading.Lock()
        self.input_connections = [f.registerCallback(self.add, i) for i, f in enumerate(fs)]

    def _make_policy(self, inputs: int) -> ExactPolicy[object] | ApproximatePolicy[object]:
        return ExactPolicy(inputs, self.queue_size)

    def add(self, msg: object, index: int) -> None:
        """Queue ``msg`` from input ``index``; call back with the sets it completes."""
        stamp = _stamp_or_warn(
            msg, self.allow_headerless, self._now, type(self).__name__, self._warned
        )
        if stamp is None:
            return
        with self._lock:
            matched = self._policy.add(index, stamp, msg)
        for messages in matched:
            self.signalMessage(*messages)


class ApproximateTimeSynchronizer(TimeSynchronizer):
    """Calls back with one message per input when their header stamps lie less than ``slop``
    seconds apart (rclpy's rule: see :mod:`zros.timesync`)."""

    def __init__(
        self,
        fs: Sequence[SimpleFilter],
        queue_size: int,
        slop: float,
        allow_headerless: bool = False,
    ) -> None:
        self.slop = slop
        self.allow_headerless = allow_headerless
        super().__init__(fs, queue_size)

    def _make_policy(self, inputs: int) -> ExactPolicy[object] | ApproximatePolicy[object]:
        return ApproximatePolicy(inputs, self.queue_size, round(self.slop * _NS))


__all__ = [
    'ApproximateTimeSynchronizer',
    'Cache',
    'SimpleFilter',
    'Subscriber',
    'TimeSynchronizer',
]
