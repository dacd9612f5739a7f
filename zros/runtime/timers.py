"""Timers and rates, driven by a node's executor (so their callbacks run where the user spins).

They follow the node's clock: the monotonic clock normally, ``/clock`` with ``use_sim_time``
(then they stop while sim time pauses and restart when it jumps back).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

from zros.runtime.signal import sleep

if TYPE_CHECKING:
    from zros.node import Node
    from zros.runtime.clock import Clock

_log = logging.getLogger('zros')
_NS = 1_000_000_000


def _nanoseconds(period: float) -> int:
    if not period > 0:
        raise ValueError(f'a period must be positive, got {period!r}')
    return max(1, round(period * _NS))


class Timer:
    """Calls ``callback()`` every ``period`` seconds (of the node's clock) while the node spins.

    A timer that falls behind skips the periods it missed instead of firing in a burst.
    """

    def __init__(self, node: Node, period: float, callback: Callable[[], object]) -> None:
        self.node = node
        self.clock: Clock = node.clock
        self.period = period
        self._period = _nanoseconds(period)
        self.callback = callback
        self._last = self.clock.timer_now()
        self._next = self._last + self._period
        self._cancelled = False
        node._executor.add_timer(self)

    @property
    def cancelled(self) -> bool:
        """Whether :meth:`cancel` was called."""
        return self._cancelled

    def seconds_until_due(self) -> float | None:
        """Wall seconds until due (<= 0: due now; None: when the sim clock moves)."""
        now = self.clock.timer_now()
        if now < self._last or self._last == 0 < now:
            # sim time jumped back (a bag looping) or /clock just started: count from now
            self._last = now
            self._next = now + self._period
        return self.clock.seconds_until(self._next)

    def _fire(self) -> None:
        now = self.clock.timer_now()
        missed = (now - self._next) // self._period
        self._next += self._period * (missed + 1)
        self._last = now
        try:
            self.callback()
        except Exception:
            _log.exception('timer callback %r of node %s raised', self.callback, self.node.name)

    def reset(self) -> None:
        """Start counting the period from now."""
        self._last = self.clock.timer_now()
        self._next = self._last + self._period

    def cancel(self) -> None:
        """Stop the timer for good."""
        if not self._cancelled:
            self._cancelled = True
            self.node._executor.remove_timer(self)


class Rate:
    """Keeps a loop at ``hz`` iterations per second; ``sleep()`` runs callbacks while it waits.

    Without a node it sleeps on the monotonic clock.
    """

    def __init__(self, hz: float, node: Node | None = None) -> None:
        if not hz > 0:
            raise ValueError(f'a rate must be positive, got {hz!r}')
        self._period = _nanoseconds(1.0 / hz)
        self.node = node
        if node is None:
            from zros.runtime.clock import Clock

            self.clock: Clock = Clock()
        else:
            self.clock = node.clock
        self._next = self.clock.timer_now() + self._period

    def sleep(self) -> None:
        """Wait until the next period starts (at once if the loop is late, or after Ctrl-C)."""
        now = self.clock.timer_now()
        if now >= self._next + self._period or now < self._next - 2 * self._period:
            self._next = now  # more than a period late, or time jumped back: start afresh
        deadline = self._next
        self._next += self._period
        if self.node is not None:
            self.node.spin_until_clock(deadline)
            return
        remaining = self.clock.seconds_until(deadline)
        if remaining is not None and remaining > 0:
            sleep(remaining)  # Ctrl-C ends it
