"""The clock of a playback: bag time mapped onto the monotonic clock, with a rate, pauses and
jumps (``rosbag2_cpp``'s TimeControllerClock, in Python)."""

from __future__ import annotations

import threading
import time

#: the last stretch before a message is due is spun, not slept (Event.wait overshoots ~0.1 ms)
SPIN_NS = 1_000_000


class PlayClock:
    """Bag time that runs ``rate`` times as fast as the monotonic clock, unless paused.

    Thread-safe; every change (pause, resume, rate, jump, :meth:`interrupt`) wakes a thread
    sleeping in :meth:`sleep_until`.
    """

    def __init__(self, start_ns: int, rate: float = 1.0) -> None:
        if not rate > 0:
            raise ValueError(f'the rate must be positive, got {rate}')
        self._lock = threading.Lock()
        self._changed = threading.Event()
        self._rate = rate
        self._bag = start_ns  #: bag time at the anchor
        self._wall = time.monotonic_ns()  #: monotonic time at the anchor
        self._paused = False

    def _now(self, wall: int) -> int:
        if self._paused:
            return self._bag
        return self._bag + round((wall - self._wall) * self._rate)

    def _anchor(self, bag: int) -> None:
        self._bag = bag
        self._wall = time.monotonic_ns()
        self._changed.set()

    def now(self) -> int:
        """The current bag time in nanoseconds."""
        with self._lock:
            return self._now(time.monotonic_ns())

    @property
    def rate(self) -> float:
        return self._rate

    @property
    def paused(self) -> bool:
        return self._paused

    def set_rate(self, rate: float) -> None:
        if not rate > 0:
            raise ValueError(f'the rate must be positive, got {rate}')
        with self._lock:
            self._anchor(self._now(time.monotonic_ns()))
            self._rate = rate

    def pause(self) -> None:
        with self._lock:
            if not self._paused:
                self._anchor(self._now(time.monotonic_ns()))
                self._paused = True

    def resume(self) -> None:
        with self._lock:
            if self._paused:
                self._paused = False
                self._anchor(self._bag)

    def jump(self, bag_ns: int) -> None:
        """Set the bag time (paused or not)."""
        with self._lock:
            self._anchor(bag_ns)

    def interrupt(self) -> None:
        """Wake a sleeping :meth:`sleep_until` (it returns False if ``stopped()`` says so)."""
        self._changed.set()

    def sleep_until(self, bag_ns: int, stopped: object = None) -> bool:
        """Sleep until the bag time reaches ``bag_ns``; False when ``stopped()`` became true.

        While paused it sleeps until resumed (or interrupted). The last millisecond is spun
        for precision.
        """
        check = stopped if callable(stopped) else (lambda: False)
        while True:
            self._changed.clear()  # before the check: a change after it still wakes the wait
            if check():
                return False
            with self._lock:
                if self._paused:
                    remaining = None
                else:
                    wall = time.monotonic_ns()
                    remaining = round((bag_ns - self._now(wall)) / self._rate)
                    due = wall + remaining
            if remaining is None:
                self._changed.wait()
                continue
            if remaining <= 0:
                return True
            if remaining > SPIN_NS:
                self._changed.wait((remaining - SPIN_NS) / 1e9)
                continue
            while time.monotonic_ns() < due:
                if self._changed.is_set():
                    break
            else:
                return not check()
