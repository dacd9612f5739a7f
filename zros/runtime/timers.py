"""Timers and rates, driven by a node's executor (so their callbacks run where the user spins).

They follow the node's clock: the monotonic clock normally, ``/clock`` with ``use_sim_time``
(then they stop while sim time pauses and restart when it jumps back).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Protocol, cast, overload

from zros.deprecation import deprecated
from zros.runtime.clock import Clock
from zros.runtime.defaults import NodeLike, default_node
from zros.runtime.signal import sleep

_log = logging.getLogger('zros')
_NS = 1_000_000_000


def _nanoseconds(period: float) -> int:
    if not period > 0:
        raise ValueError(f'a period must be positive, got {period!r}')
    return max(1, round(period * _NS))


class Timer:
    """Calls ``callback()`` every ``period`` seconds (of the node's clock) while the node spins
    (``node`` None: the default node of ``zros.init``; ``node.create_timer`` is rclpy's way).

    A timer that falls behind skips the periods it missed instead of firing in a burst.
    """

    @overload
    def __init__(
        self, period: float, callback: Callable[[], object], *, node: NodeLike | None = None
    ) -> None: ...

    @overload
    def __init__(self, period: NodeLike, callback: float, node: Callable[[], object]) -> None:
        """Deprecated: ``Timer(node, period, callback)``."""

    def __init__(
        self,
        period: float | NodeLike,
        callback: Callable[[], object] | float,
        node: NodeLike | Callable[[], object] | None = None,
    ) -> None:
        if isinstance(period, (int, float)) and callable(callback):
            if node is not None and not hasattr(node, 'context'):
                raise TypeError(f'node= takes a node, not {type(node).__name__}')
            owner = cast('NodeLike | None', node)
        elif hasattr(period, 'context') and isinstance(callback, (int, float)) and callable(node):
            deprecated('Timer(node, period, callback)', 'Timer(period, callback, node=node)')
            owner, period, callback = cast('NodeLike', period), callback, node
        else:
            raise TypeError('Timer takes (period, callback, node=None)')
        node = owner if owner is not None else default_node()
        context = node.context
        context.check_open()
        self.node = node
        self._executor = context.executor
        self.clock: Clock = context.clock
        self.period = period
        self._period = _nanoseconds(period)
        self.callback = callback
        self._last = self.clock.timer_now()
        self._next = self._last + self._period
        self._switches = self.clock.switches
        self._cancelled = False
        self._owner = context.name
        self._executor.add_timer(self)

    @property
    def cancelled(self) -> bool:
        """Whether :meth:`cancel` was called."""
        return self._cancelled

    def is_canceled(self) -> bool:
        """Whether :meth:`cancel` was called (rclpy's name)."""
        return self._cancelled

    @property
    def timer_period_ns(self) -> int:
        """The period in nanoseconds (rclpy's); setting it counts the periods after the call
        now due."""
        return self._period

    @timer_period_ns.setter
    def timer_period_ns(self, nanoseconds: int) -> None:
        if not nanoseconds > 0:
            raise ValueError(f'a period must be positive, got {nanoseconds!r} ns')
        self._period = nanoseconds  # the call due keeps its time, as rcl's
        self.period = nanoseconds / _NS

    def is_ready(self) -> bool:
        """Whether the timer is due (its callback runs at the next spin), as rclpy's."""
        due = self.seconds_until_due()
        return not self._cancelled and due is not None and due <= 0

    def time_until_next_call(self) -> int | None:
        """Nanoseconds of the node's clock until the timer is due (negative: overdue), None
        once cancelled, as rclpy's."""
        if self._cancelled:
            return None
        self.seconds_until_due()  # restarts the count when the clock jumped back or switched
        return self._next - self.clock.timer_now()

    def time_since_last_call(self) -> int:
        """Nanoseconds of the node's clock since the callback last ran (or the timer started,
        or was reset), as rclpy's."""
        return self.clock.timer_now() - self._last

    def seconds_until_due(self) -> float | None:
        """Wall seconds until due (<= 0: due now; None: when the sim clock moves)."""
        now = self.clock.timer_now()
        if now < self._last or self._last == 0 < now or self._switches != self.clock.switches:
            # sim time jumped back (a bag looping), /clock just started, or use_sim_time
            # switched the time base: count from now
            self._switches = self.clock.switches
            self._last = now
            self._next = now + self._period
        return self.clock.seconds_until(self._next)

    def fire(self) -> None:
        """Run the callback now and count the next period from its due time (the executor
        calls it when due; missed periods are skipped)."""
        now = self.clock.timer_now()
        missed = (now - self._next) // self._period
        self._next += self._period * (missed + 1)
        self._last = now
        try:
            self.callback()
        except Exception:  # a user callback: logged, the timer goes on
            _log.exception('timer callback %r of node %s raised', self.callback, self._owner)

    def reset(self) -> None:
        """Start counting the period from now."""
        self._last = self.clock.timer_now()
        self._next = self._last + self._period

    def cancel(self) -> None:
        """Stop the timer for good."""
        if not self._cancelled:
            self._cancelled = True
            self._executor.remove_timer(self)

    #: rclpy's ``Timer.destroy`` (``node.destroy_timer(timer)`` does the same)
    destroy = cancel


class Spinnable(Protocol):
    """A node, as a :class:`Rate` sees it."""

    @property
    def clock(self) -> Clock:
        """The node's clock."""

    def spin_until_clock(self, deadline: int) -> None:
        """Run the node's callbacks until its clock's timer base reaches ``deadline``."""


class Rate:
    """Keeps a loop at ``hz`` iterations per second; ``sleep()`` runs callbacks while it waits.

    With ``node=`` it follows that node's clock and runs its callbacks while it waits
    (``node.create_rate`` is rclpy's way); without one it sleeps on the monotonic clock, even
    after ``zros.init``: a rate needs no node, and one that spun the default node unasked
    would run callbacks where the program does not expect them.
    """

    def __init__(self, hz: float, *args: Spinnable, node: Spinnable | None = None) -> None:
        if args:
            if node is not None or len(args) > 1:
                raise TypeError('Rate takes (hz, node=None)')
            deprecated('Rate(hz, node)', 'Rate(hz, node=node)')
            node = args[0]
        if not hz > 0:
            raise ValueError(f'a rate must be positive, got {hz!r}')
        self._period = _nanoseconds(1.0 / hz)
        self.node = node
        self.clock: Clock = Clock() if node is None else node.clock
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
