"""The matching rules of message synchronizers, on stamps in integer nanoseconds.

Pure bookkeeping (no node, no clock, no lock): ``zros.message_filters`` feeds it live messages
and ``Bag.synchronize`` a recording's, so both match the same way. The rules are those of
rclpy's ``message_filters`` (the Python package): each input keeps a queue of stamp -> item
(a newer item with the same stamp replaces the older; past ``queue_size`` the oldest stamp is
dropped). :class:`ExactPolicy` emits every stamp present in all queues, oldest first.
:class:`ApproximatePolicy`, when an item arrives, looks in the other queues for items within
``slop`` of its stamp, tries their combinations closest first (in input order) and emits the
first whose stamps span less than ``slop``; each arrival emits at most one set.
"""

from __future__ import annotations

import itertools
import numbers
from collections.abc import Sequence
from typing import Generic, TypeVar

T = TypeVar('T')
_NS = 1_000_000_000


def integer_ns(value: object) -> int | None:
    """``value`` as an int when it is an integer of any kind (``int``, ``numpy.int64``, …;
    never a bool), else None: times in nanoseconds come as numpy integers from bag columns."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)
    return None


def header_stamp(message: object) -> int | None:
    """``message.header.stamp`` in integer nanoseconds, or None when it has none."""
    stamp = getattr(getattr(message, 'header', None), 'stamp', None)
    if stamp is None:
        return None
    nanoseconds = integer_ns(getattr(stamp, 'nanoseconds', None))
    if nanoseconds is not None:
        return nanoseconds
    return int(stamp.sec) * _NS + int(stamp.nanosec)


class _Queues(Generic[T]):
    def __init__(self, inputs: int, queue_size: int) -> None:
        if inputs < 1:
            raise ValueError('a synchronizer needs at least one input')
        if queue_size < 1:
            raise ValueError(f'queue_size must be at least 1, got {queue_size}')
        self.queue_size = queue_size
        self.queues: list[dict[int, T]] = [{} for _ in range(inputs)]

    def _put(self, index: int, stamp: int, item: T) -> None:
        queue = self.queues[index]
        queue[stamp] = item
        while len(queue) > self.queue_size:
            del queue[min(queue)]


class ExactPolicy(_Queues[T]):
    """Sets of items whose stamps are equal on every input."""

    def add(self, index: int, stamp: int, item: T) -> list[tuple[T, ...]]:
        """Queue ``item`` (stamp in ns) on input ``index``; the sets it completes."""
        self._put(index, stamp, item)
        common = set(self.queues[0]).intersection(*self.queues[1:])
        matched = []
        for each in sorted(common):
            matched.append(tuple(queue.pop(each) for queue in self.queues))
        return matched


class ApproximatePolicy(_Queues[T]):
    """Sets of items whose stamps lie less than ``slop_ns`` apart (rclpy's rule, above)."""

    def __init__(self, inputs: int, queue_size: int, slop_ns: int) -> None:
        super().__init__(inputs, queue_size)
        if slop_ns < 0:
            raise ValueError(f'slop must not be negative, got {slop_ns} ns')
        self.slop_ns = slop_ns

    def add(self, index: int, stamp: int, item: T) -> list[tuple[T, ...]]:
        """Queue ``item`` (stamp in ns) on input ``index``; the set it completes, if any."""
        self._put(index, stamp, item)
        if stamp not in self.queues[index]:
            return []  # the oldest of a full queue: dropped at once
        slop = self.slop_ns
        candidates: list[Sequence[int]] = []
        for other, queue in enumerate(self.queues):
            if other == index:
                candidates.append((stamp,))
                continue
            near = [s for s in queue if abs(s - stamp) <= slop]
            if not near:
                return []
            candidates.append(sorted(near, key=lambda s: abs(s - stamp)))
        for stamps in itertools.product(*candidates):
            if max(stamps) - min(stamps) < slop:
                return [tuple(q.pop(s) for q, s in zip(self.queues, stamps, strict=True))]
        return []


__all__ = ['ApproximatePolicy', 'ExactPolicy', 'header_stamp']
