"""The unread samples of one subscription: filled on Zenoh's thread, emptied by its readers.

Zenoh delivers every subscription of a session through one path: a callback that waits stalls
all of them, and the session's queryables (parameters, services) with them. So putting a sample
never waits. Keep-last holds the newest ``depth`` samples; keep-all holds every sample up to a
memory bound (payloads plus :data:`SAMPLE_OVERHEAD` each) and an optional count, and refuses
the rest, which the subscriber counts and reports.
"""

from __future__ import annotations

import collections
import threading
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zenoh import Sample

#: a keep-all subscriber holds unread messages up to this many bytes, then drops new ones
KEEP_ALL_BYTES = 256 * 1024 * 1024
#: what a queued sample costs besides its payload (Zenoh's sample and its Python object)
SAMPLE_OVERHEAD = 384


def _cost(sample: Sample) -> int:
    return len(sample.payload) + SAMPLE_OVERHEAD


class SampleQueue:
    """Unread samples, oldest first: keep-last ``depth``, or keep-all (``depth`` None) up to
    ``max_bytes`` and ``max_count``. Thread-safe; :meth:`put` never blocks."""

    def __init__(self, depth: int | None, max_count: int | None, max_bytes: int | None) -> None:
        if max_count is not None and max_count < 1:
            raise ValueError(f'max_queue must be at least 1, got {max_count}')
        if max_bytes is not None and max_bytes < 1:
            raise ValueError(f'max_queue_bytes must be at least 1, got {max_bytes}')
        self._items: collections.deque[Sample] = collections.deque(maxlen=depth)
        #: the number of unread samples, as a C call (``len(queue)`` runs a Python method:
        #: a wait tests this once per message)
        self.unread = self._items.__len__
        self.max_count = max_count if depth is None else None
        self.max_bytes = max_bytes if depth is None else None
        self._bytes = 0  #: keep-all: what the queue holds, overheads included
        self._lock = threading.Lock()
        self.received = 0  #: samples offered (refused and rejected ones included)
        self.overflowed = 0  #: samples refused past the bounds
        self.rejected = 0  #: samples the subscriber turned away before queueing them

    def __bool__(self) -> bool:
        return bool(self._items)

    def __len__(self) -> int:
        return len(self._items)

    @property
    def nbytes(self) -> int:
        """Keep-all: the bytes held, overheads included (0 for keep-last)."""
        return self._bytes

    def put(self, samples: list[Sample]) -> int:
        """Queue ``samples`` in order; returns how many a keep-all queue refused at its bounds
        (they are dropped)."""
        limit = self.max_bytes
        items = self._items
        if limit is None:
            with self._lock:
                self.received += len(samples)
                items.extend(samples)
            return 0
        sizes = [len(sample.payload) for sample in samples]
        batch = sum(sizes) + SAMPLE_OVERHEAD * len(samples)
        refused = 0
        with self._lock:
            self.received += len(samples)
            count_limit = self.max_count
            if self._bytes + batch <= limit and (
                count_limit is None or len(items) + len(samples) <= count_limit
            ):  # the usual case: the whole batch fits
                items.extend(samples)
                self._bytes += batch
                return 0
            for sample, payload in zip(samples, sizes, strict=True):
                size = payload + SAMPLE_OVERHEAD
                if self._bytes + size > limit or (
                    count_limit is not None and len(items) >= count_limit
                ):
                    refused += 1
                    continue
                items.append(sample)
                self._bytes += size
            self.overflowed += refused
        return refused

    def passing(self, samples: list[Sample]) -> list[Sample]:
        """Count ``samples`` received without queueing them (immediate callbacks); returns
        those the queue would have kept: all of them, or keep-last's newest ``depth``."""
        with self._lock:
            self.received += len(samples)
        depth = self._items.maxlen
        return samples if depth is None or len(samples) <= depth else samples[-depth:]

    def reject(self) -> None:
        """Count a sample turned away before queueing (received, and lost)."""
        with self._lock:
            self.received += 1
            self.rejected += 1

    def newest(self) -> Sample | None:
        """The newest unread sample, or None."""
        try:
            return self._items[-1]
        except IndexError:
            return None

    def pop(self, limit: int | None = None) -> list[Sample]:
        """Up to ``limit`` (None: every) unread samples, oldest first."""
        with self._lock:
            items = self._items
            if limit is None or limit >= len(items):
                samples = list(items)
                items.clear()
                self._bytes = 0
                return samples
            samples = [items.popleft() for _ in range(limit)]
            if self.max_bytes is not None:
                self._bytes -= sum(map(_cost, samples))
            return samples

    def discard(self, sample: Sample) -> None:
        """Take ``sample`` out, wherever it is (a keep-last queue may have pushed it out)."""
        with self._lock:
            items = self._items
            if items and items[-1] is sample:
                items.pop()
            else:
                try:
                    items.remove(sample)
                except ValueError:
                    return
            if self.max_bytes is not None:
                self._bytes -= _cost(sample)

    def describe_full(self) -> str:
        """Why :meth:`put` refuses: the bounds and what the queue holds."""
        bound = f'max_queue_bytes={self.max_bytes}'
        if self.max_count is not None:
            bound += f', max_queue={self.max_count}'
        return (
            f'its keep-all queue holds {len(self._items)} unread messages ({self._bytes} bytes '
            f'with overheads; {bound}): read faster, or give the subscriber a larger bound'
        )
