"""rclpy's ``timeout_sec=`` beside zros's ``timeout=``: either spelling, not both."""

from __future__ import annotations

import enum
from typing import Literal


class _Unset(enum.Enum):
    UNSET = enum.auto()


UNSET = _Unset.UNSET
#: the type of a keyword left out (``UNSET``)
Unset = Literal[_Unset.UNSET]


def either_timeout(
    timeout: float | Unset | None, timeout_sec: float | Unset | None, default: float | None
) -> float | None:
    """``timeout``, or rclpy's ``timeout_sec`` given instead; ``default`` when neither is
    (``timeout`` equal to ``default`` counts as not given)."""
    if timeout_sec is UNSET:
        return default if timeout is UNSET else timeout
    if timeout is not UNSET and timeout != default:
        raise TypeError("give timeout= or rclpy's timeout_sec=, not both")
    return timeout_sec
