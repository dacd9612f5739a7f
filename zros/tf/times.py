"""Times and timeouts as tf2_ros takes them: integer nanoseconds, zros's or rclpy's ``Time`` and
``Duration``, or a ``builtin_interfaces/msg/Time``."""

from __future__ import annotations

from typing import Protocol

from zros.runtime.clock import Duration, Time
from zros.tf.errors import InvalidArgumentException
from zros.timesync import integer_ns

_NS = 1_000_000_000


class HasStamp(Protocol):
    """A ``builtin_interfaces/msg/Time``."""

    sec: int
    nanosec: int


class HasNanoseconds(Protocol):
    """A time or duration with integer ``nanoseconds`` (rclpy's ``Time`` and ``Duration``)."""

    @property
    def nanoseconds(self) -> int:
        """The value in integer nanoseconds."""


#: a time: integer nanoseconds, a zros.Time (or rclpy's), or a builtin_interfaces/msg/Time
TimeLike = int | Time | HasStamp | HasNanoseconds
#: a timeout: seconds, or a zros.Duration (or rclpy's)
TimeoutLike = float | Duration | HasNanoseconds | None


def nanoseconds(time: TimeLike, argument: str = 'time') -> int:
    """A time as integer nanoseconds (0 means the latest common time)."""
    nanoseconds_of = getattr(time, 'nanoseconds', None)  # zros.Time, rclpy.time.Time
    integer = integer_ns(time)
    if integer is not None:
        value = integer
    elif isinstance(nanoseconds_of, int):
        value = nanoseconds_of
    elif hasattr(time, 'sec') and hasattr(time, 'nanosec'):
        value = int(time.sec) * _NS + int(time.nanosec)
    else:
        hint = ' (for seconds, use zros.Time.from_seconds)' if isinstance(time, float) else ''
        raise InvalidArgumentException(
            f'{argument} must be integer nanoseconds, a zros.Time or a '
            f'builtin_interfaces/msg/Time, not {type(time).__name__}{hint}'
        )
    if value < 0:
        raise InvalidArgumentException(f'{argument} is negative ({value} ns)')
    return value


def seconds(timeout: TimeoutLike) -> float | None:
    """A timeout in seconds (None: wait for ever)."""
    if timeout is None:
        return None
    nanoseconds_of = getattr(timeout, 'nanoseconds', None)  # zros or rclpy Duration
    if isinstance(nanoseconds_of, int):
        return nanoseconds_of / _NS
    return float(timeout)  # type: ignore[arg-type]  # a number, else float raises


def format_time(stamp: int) -> str:
    """Nanoseconds as seconds with all nine decimals."""
    sec, nanosec = divmod(stamp, _NS)
    return f'{sec}.{nanosec:09d}'
