"""Quality of service of publishers and subscribers, as in ROS 2.

Only the policies that cross a zenoh-bridge-ros2dds are modelled: reliability, durability and
history (kind and depth). The enum values are the ones the bridge writes into its tokens.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace
from typing import Union


class Reliability(enum.IntEnum):
    """Whether every message must arrive (RELIABLE) or the newest is enough (BEST_EFFORT)."""

    BEST_EFFORT = 0
    RELIABLE = 1


class Durability(enum.IntEnum):
    """Whether late subscribers get the last messages (TRANSIENT_LOCAL) or only new ones."""

    VOLATILE = 0
    TRANSIENT_LOCAL = 1


class History(enum.IntEnum):
    """Keep the last ``depth`` messages, or all of them."""

    KEEP_LAST = 0
    KEEP_ALL = 1


@dataclass(frozen=True)
class QoS:
    """A QoS profile; ``QoS(10)`` is ROS 2's default (reliable, volatile, keep last 10)."""

    depth: int = 10
    reliability: Reliability = Reliability.RELIABLE
    durability: Durability = Durability.VOLATILE
    history: History = History.KEEP_LAST

    def __post_init__(self) -> None:
        if self.history is History.KEEP_LAST and self.depth < 1:
            raise ValueError(f'a keep-last QoS needs depth >= 1, got {self.depth}')

    @property
    def reliable(self) -> bool:
        """Whether the reliability is RELIABLE."""
        return self.reliability is Reliability.RELIABLE

    @property
    def transient_local(self) -> bool:
        """Whether the durability is TRANSIENT_LOCAL (latched)."""
        return self.durability is Durability.TRANSIENT_LOCAL

    @property
    def keep_all(self) -> bool:
        """Whether the history keeps every message."""
        return self.history is History.KEEP_ALL

    def with_(self, **changes: object) -> QoS:
        """A copy with some policies changed."""
        return replace(self, **changes)  # type: ignore[arg-type]

    def __str__(self) -> str:
        history = 'keep all' if self.keep_all else f'keep last {self.depth}'
        return f'{self.reliability.name.lower()}, {self.durability.name.lower()}, {history}'


#: ROS 2's ``rclpy.qos.qos_profile_sensor_data``
SENSOR_DATA = QoS(5, Reliability.BEST_EFFORT)
#: ROS 2's default for publishers and subscribers
DEFAULT = QoS(10)
#: latched topics such as /tf_static, /map and /robot_description
LATCHED = QoS(1, durability=Durability.TRANSIENT_LOCAL)
#: /rosout (reliable, transient local, keep last 1000)
ROSOUT = QoS(1000, durability=Durability.TRANSIENT_LOCAL)
#: /parameter_events
PARAMETER_EVENTS = QoS(1000)
#: every message kept until read (bounded by memory, not by depth)
KEEP_ALL = QoS(1000, history=History.KEEP_ALL)

_PRESETS = {
    'default': DEFAULT,
    'sensor_data': SENSOR_DATA,
    'latched': LATCHED,
    'transient_local': LATCHED,
    'rosout': ROSOUT,
    'parameter_events': PARAMETER_EVENTS,
    'keep_all': KEEP_ALL,
}

QoSLike = Union[QoS, int, str]  # noqa: UP007 (a runtime alias, used in signatures)


def as_qos(value: QoSLike | None) -> QoS:
    """A QoS from a QoS, a depth (as rclpy takes ``10``) or a preset name (``'sensor_data'``)."""
    if value is None:
        return DEFAULT
    if isinstance(value, QoS):
        return value
    if isinstance(value, bool):
        raise TypeError('a QoS is a zros.QoS, a depth or a preset name, not a bool')
    if isinstance(value, int):
        return QoS(value)
    if isinstance(value, str):
        try:
            return _PRESETS[value]
        except KeyError:
            raise ValueError(
                f'unknown QoS preset {value!r}; presets: {", ".join(sorted(_PRESETS))}'
            ) from None
    raise TypeError(f'a QoS is a zros.QoS, a depth or a preset name, not {type(value).__name__}')
