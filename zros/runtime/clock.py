"""ROS time: ``Time``, ``Duration`` and the clocks nodes run on (system time or ``/clock``).

With ``use_sim_time`` a node's clock follows ``rosgraph_msgs/msg/Clock`` messages on ``/clock``
(as published by a bag player or a simulator): it stands still until the first one, pauses when
they stop and jumps when they jump. Timers and rates of the node follow that clock.
"""

from __future__ import annotations

import datetime
import operator
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import overload

from zros.cdr import Message, new_message
from zros.runtime.signal import Signal

_NS = 1_000_000_000


def _nanoseconds(seconds: float) -> int:
    return round(seconds * _NS)


def _total(kind: str, nanoseconds: int, seconds: float) -> int:
    """The integer nanoseconds of ``kind(nanoseconds, seconds=)``; a float as nanoseconds (an
    rclpy habit, ``Duration(0.5)``) would be a silent 0, so it raises."""
    if type(nanoseconds) is not int:
        try:
            nanoseconds = operator.index(nanoseconds)
        except TypeError:
            raise TypeError(
                f'{kind}() takes integer nanoseconds, not {nanoseconds!r}: '
                f'for seconds write {kind}(seconds={nanoseconds!r}) '
                f'or {kind}.from_seconds({nanoseconds!r})'
            ) from None
    if seconds:
        return nanoseconds + _nanoseconds(seconds)
    return nanoseconds


@dataclass(frozen=True, order=True, init=False)
class Duration:
    """A span of ROS time, in integer nanoseconds (negative spans are allowed):
    ``Duration(1_500_000_000)``, or rclpy's ``Duration(seconds=1, nanoseconds=500_000_000)``."""

    nanoseconds: int

    def __init__(self, nanoseconds: int = 0, *, seconds: float = 0) -> None:
        object.__setattr__(self, 'nanoseconds', _total('Duration', nanoseconds, seconds))

    @classmethod
    def from_seconds(cls, seconds: float) -> Duration:
        """A duration of ``seconds`` (a float), rounded to nanoseconds."""
        return cls(_nanoseconds(seconds))

    @classmethod
    def from_msg(cls, message: Message) -> Duration:
        """From a ``builtin_interfaces/msg/Duration``."""
        return cls(message.sec * _NS + message.nanosec)

    def to_msg(self) -> Message:
        """A ``builtin_interfaces/msg/Duration``."""
        sec, nanosec = divmod(self.nanoseconds, _NS)
        return new_message('builtin_interfaces/msg/Duration', sec=sec, nanosec=nanosec)

    def __float__(self) -> float:
        return self.nanoseconds / _NS

    @property
    def seconds(self) -> float:
        """The duration in seconds, as a float."""
        return self.nanoseconds / _NS

    def __add__(self, other: Duration) -> Duration:
        if not isinstance(other, Duration):
            return NotImplemented
        return Duration(self.nanoseconds + other.nanoseconds)

    def __sub__(self, other: Duration) -> Duration:
        if not isinstance(other, Duration):
            return NotImplemented
        return Duration(self.nanoseconds - other.nanoseconds)

    def __mul__(self, factor: float) -> Duration:
        return Duration(round(self.nanoseconds * factor))

    __rmul__ = __mul__

    def __truediv__(self, divisor: float) -> Duration:
        return Duration(round(self.nanoseconds / divisor))

    def __neg__(self) -> Duration:
        return Duration(-self.nanoseconds)

    def __repr__(self) -> str:
        return f'Duration({self.seconds:.9f} s)'


@dataclass(frozen=True, order=True, init=False)
class Time:
    """A ROS time stamp, in integer nanoseconds since the epoch (or since sim time 0):
    ``Time(1_500_000_000)``, or rclpy's ``Time(seconds=1, nanoseconds=500_000_000)``."""

    nanoseconds: int

    def __init__(self, nanoseconds: int = 0, *, seconds: float = 0) -> None:
        object.__setattr__(self, 'nanoseconds', _total('Time', nanoseconds, seconds))

    @classmethod
    def from_seconds(cls, seconds: float) -> Time:
        """A time of ``seconds`` since the epoch (a float), rounded to nanoseconds."""
        return cls(_nanoseconds(seconds))

    @classmethod
    def from_msg(cls, message: Message) -> Time:
        """From a ``builtin_interfaces/msg/Time`` (e.g. ``msg.header.stamp``)."""
        return cls(message.sec * _NS + message.nanosec)

    def to_msg(self) -> Message:
        """A ``builtin_interfaces/msg/Time``, ready for ``msg.header.stamp``."""
        sec, nanosec = divmod(self.nanoseconds, _NS)
        return new_message('builtin_interfaces/msg/Time', sec=sec, nanosec=nanosec)

    @property
    def sec(self) -> int:
        """Whole seconds since the epoch (``builtin_interfaces/Time.sec``)."""
        return self.nanoseconds // _NS

    @property
    def nanosec(self) -> int:
        """The nanoseconds past :attr:`sec` (``builtin_interfaces/Time.nanosec``)."""
        return self.nanoseconds % _NS

    def seconds_nanoseconds(self) -> tuple[int, int]:
        """``(sec, nanosec)``: whole seconds and the nanoseconds past them (rclpy's)."""
        return self.sec, self.nanosec

    def __float__(self) -> float:
        return self.nanoseconds / _NS

    @property
    def seconds(self) -> float:
        """Seconds since the epoch, as a float (loses nanoseconds today)."""
        return self.nanoseconds / _NS

    def to_datetime(self) -> datetime.datetime:
        """The time as an aware UTC datetime (microsecond precision)."""
        epoch = datetime.datetime(1970, 1, 1, tzinfo=datetime.timezone.utc)
        return epoch + datetime.timedelta(microseconds=self.nanoseconds // 1000)

    def __add__(self, other: Duration) -> Time:
        if not isinstance(other, Duration):
            return NotImplemented
        return Time(self.nanoseconds + other.nanoseconds)

    __radd__ = __add__

    @overload
    def __sub__(self, other: Time) -> Duration: ...

    @overload
    def __sub__(self, other: Duration) -> Time: ...

    def __sub__(self, other: Time | Duration) -> Time | Duration:
        if isinstance(other, Time):
            return Duration(self.nanoseconds - other.nanoseconds)
        if isinstance(other, Duration):
            return Time(self.nanoseconds - other.nanoseconds)
        return NotImplemented

    def __str__(self) -> str:
        return f'{self.sec}.{self.nanosec:09d}'

    def __repr__(self) -> str:
        return f'Time({self})'


class Clock:
    """The system clock: ``now()`` is wall time; timers count on the monotonic clock."""

    @property
    def sim(self) -> bool:
        """Whether the clock follows ``/clock`` now."""
        return False

    @property
    def switches(self) -> int:
        """How many times the clock changed its time base (timers restart when it grows)."""
        return 0

    def now(self) -> Time:
        """The current time."""
        return Time(time.time_ns())

    def timer_now(self) -> int:
        """Nanoseconds on the time base of this clock's timers (never jumps for system time)."""
        return time.monotonic_ns()

    def seconds_until(self, due: int) -> float | None:
        """Wall seconds to wait until ``timer_now()`` reaches ``due``; None: until woken."""
        return (due - time.monotonic_ns()) / _NS

    def add_listener(self, wake: Callable[[], None]) -> None:
        """Sim clocks wake listeners on every update; the system clock never needs to."""

    def remove_listener(self, wake: Callable[[], None]) -> None:
        """Stop calling ``wake`` on time changes (the wall clock has none)."""
        pass


class SimClock(Clock):
    """Time read from ``/clock``; zero until the first message arrives. ``active=False`` (or
    :meth:`switch`) makes it the system clock until switched back, as ``use_sim_time`` does."""

    def __init__(self, active: bool = True) -> None:
        self._active = active
        self._switches = 0
        self._now = 0
        self._listeners: list[Callable[[], None]] = []
        self._updated = Signal()
        self._lock = threading.Lock()
        self.received = 0

    @property
    def sim(self) -> bool:
        """Whether the clock follows ``/clock`` now (else it is the system clock)."""
        return self._active

    def switch(self, active: bool) -> None:
        """Follow ``/clock`` (True) or the system clock (False) from now on; wakes listeners so
        waiting timers count on the new time base."""
        if active != self._active:
            self._active = active
            self._switches += 1
        self._wake()

    @property
    def switches(self) -> int:
        """How many times :meth:`switch` changed the time base."""
        return self._switches

    def now(self) -> Time:
        """The latest time ``/clock`` gave (0 before the first)."""
        return Time(self._now) if self._active else super().now()

    def set(self, stamp: Time) -> None:
        """Move the clock (called for every ``/clock`` message)."""
        self._now = stamp.nanoseconds
        self.received += 1
        self._wake()

    def _wake(self) -> None:
        for wake in tuple(self._listeners):
            wake()
        if self._updated:
            self._updated.notify()

    def timer_now(self) -> int:
        """The nanoseconds timers count in: sim time (monotonic time while switched off)."""
        return self._now if self._active else super().timer_now()

    def seconds_until(self, due: int) -> float | None:
        """None (wait for the next ``/clock``) before ``due``, else 0."""
        if not self._active:
            return super().seconds_until(due)
        # sim time moves only when /clock says so: wait for the next update
        return None if due > self._now else 0.0

    def add_listener(self, wake: Callable[[], None]) -> None:
        """Call ``wake()`` (from Zenoh's thread) whenever ``/clock`` moves."""
        with self._lock:
            self._listeners.append(wake)

    def remove_listener(self, wake: Callable[[], None]) -> None:
        """Stop calling ``wake`` when ``/clock`` moves."""
        with self._lock:
            if wake in self._listeners:
                self._listeners.remove(wake)

    def sleep_until(self, due: Time, timeout: float | None = None) -> bool:
        """Block until the clock reaches ``due`` (False when ``timeout`` wall seconds pass, and
        after Ctrl-C)."""
        return self._updated.wait_for(lambda: self._now >= due.nanoseconds, timeout)


def use_sim_time_from_environment() -> bool:
    """``ZROS_USE_SIM_TIME=1`` (or true/yes/on) asks every node for sim time."""
    return os.environ.get('ZROS_USE_SIM_TIME', '').strip().lower() in ('1', 'true', 'yes', 'on')
