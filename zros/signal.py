"""A wake-up primitive lighter than ``threading.Condition``.

A Condition wakes its waiter while the notifier still holds the condition's lock, so the woken
thread blocks again at once to reacquire it: two scheduler round trips per wake-up. Here each
waiter sleeps on a lock of its own that the notifier releases, and re-checks its predicate after
registering, so no wake-up is lost.
"""

from __future__ import annotations

import _thread
import contextlib
from collections.abc import Callable


class Signal:
    """Lets threads sleep until another thread says something may have changed."""

    __slots__ = ('_waiters',)

    def __init__(self) -> None:
        self._waiters: list[_thread.LockType] = []

    def __bool__(self) -> bool:
        """Whether a thread is waiting (notifying costs nothing otherwise)."""
        return bool(self._waiters)

    def wait(self, ready: Callable[[], object], timeout: float | None) -> None:
        """Sleep until notified or ``timeout`` seconds pass, unless ``ready()`` is already true."""
        lock = _thread.allocate_lock()
        lock.acquire()
        self._waiters.append(lock)
        try:
            if not ready():
                lock.acquire(True, -1 if timeout is None else max(timeout, 0.0))
        finally:
            self._waiters.remove(lock)

    def notify(self) -> None:
        """Wake every waiting thread."""
        for lock in tuple(self._waiters):
            with contextlib.suppress(RuntimeError):  # already released by an earlier notify
                lock.release()
