"""A client's bounded outbox: it drops its oldest items and counts them, so a slow client never
makes the sender wait."""

from __future__ import annotations

import collections
import logging
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

from zros.runtime.signal import Signal

_log = logging.getLogger('zros.gateway')

T = TypeVar('T')


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
