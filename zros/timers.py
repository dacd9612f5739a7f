"""Timers and rates, driven by a node's executor (so their callbacks run where the user spins)."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zros.node import Node

_log = logging.getLogger('zros')


def _seconds(period: float) -> float:
    if not period > 0:
        raise ValueError(f'a period must be positive, got {period!r}')
    return float(period)


class Timer:
    """Calls ``callback()`` every ``period`` seconds from ``spin_once``/``spin`` of its node.

    A timer that falls behind skips the periods it missed instead of firing in a burst.
    """

    def __init__(self, node: Node, period: float, callback: Callable[[], object]) -> None:
        self.node = node
        self.period = _seconds(period)
        self.callback = callback
        self._next = time.monotonic() + self.period
        self._cancelled = False
        node._executor.add_timer(self)

    @property
    def cancelled(self) -> bool:
        return self._cancelled

    def time_until_due(self, now: float) -> float:
        return self._next - now

    def _fire(self, now: float) -> None:
        missed = int((now - self._next) // self.period)
        self._next += self.period * (missed + 1)
        try:
            self.callback()
        except Exception:
            _log.exception('timer callback %r of node %s raised', self.callback, self.node.name)

    def reset(self) -> None:
        """Start counting the period from now."""
        self._next = time.monotonic() + self.period

    def cancel(self) -> None:
        """Stop the timer for good."""
        if not self._cancelled:
            self._cancelled = True
            self.node._executor.remove_timer(self)


class Rate:
    """Keeps a loop at ``hz`` iterations per second; ``sleep()`` runs callbacks while it waits."""

    def __init__(self, hz: float, node: Node | None = None) -> None:
        self.period = 1.0 / _seconds(hz)
        self.node = node
        self._next = time.monotonic() + self.period

    def sleep(self) -> None:
        """Wait until the next period starts (at once if the loop is late)."""
        now = time.monotonic()
        if now >= self._next + self.period:  # more than a period late: start afresh
            self._next = now
        deadline = self._next
        self._next += self.period
        if self.node is not None:
            self.node.spin_until(deadline)
        else:
            remaining = deadline - time.monotonic()
            if remaining > 0:
                time.sleep(remaining)
