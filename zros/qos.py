"""Quality of service of publishers and subscribers, as in ROS 2.

The policies that cross a zenoh-bridge-ros2dds are modelled: reliability, durability and
history (kind and depth); the enum values are the ones the bridge writes into its tokens.
``lifespan`` is ROS 2's, applied by zros's subscribers. ``congestion``, ``priority`` and
``express`` are Zenoh's, zros extensions no token carries (docs/qos.md says how zros chooses
them).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, TypedDict, TypeVar, Union

if TYPE_CHECKING:
    from typing_extensions import Unpack


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


class Congestion(enum.Enum):
    """What a publisher does when the network cannot take a message right now (Zenoh's
    congestion control): DROP it, BLOCK until it can, or BLOCK_FIRST (block on one message,
    drop the others until that one is sent)."""

    DROP = 'drop'
    BLOCK = 'block'
    BLOCK_FIRST = 'block_first'


class Priority(enum.IntEnum):
    """Zenoh's priorities, 1 (first) to 7 (last), as zenoh-bridge-ros2dds numbers them."""

    REAL_TIME = 1
    INTERACTIVE_HIGH = 2
    INTERACTIVE_LOW = 3
    DATA_HIGH = 4
    DATA = 5
    DATA_LOW = 6
    BACKGROUND = 7


class QoSChanges(TypedDict, total=False):
    """The policies :meth:`QoS.with_` may change (each a field of :class:`QoS`)."""

    depth: int
    reliability: Reliability
    durability: Durability
    history: History
    lifespan: float | None
    congestion: Congestion | None
    priority: Priority | None
    express: bool | None


@dataclass(frozen=True)
class QoS:
    """A QoS profile; ``QoS(10)`` is ROS 2's default (reliable, volatile, keep last 10).

    ``lifespan`` (seconds): subscribers drop messages older than that on arrival, counted.
    ``congestion``: None chooses as rmw_zenoh does (:attr:`congestion_control`).
    ``priority`` and ``express``: None chooses by the topic and type (docs/qos.md).
    """

    depth: int = 10
    reliability: Reliability = Reliability.RELIABLE
    durability: Durability = Durability.VOLATILE
    history: History = History.KEEP_LAST
    lifespan: float | None = None
    congestion: Congestion | None = None
    priority: Priority | None = None
    express: bool | None = None

    def __post_init__(self) -> None:
        if self.history is History.KEEP_LAST and self.depth < 1:
            raise ValueError(f'a keep-last QoS needs depth >= 1, got {self.depth}')
        if self.lifespan is not None and not self.lifespan > 0:
            raise ValueError(f'a lifespan is a number of seconds > 0, got {self.lifespan}')
        if self.congestion is not None:
            object.__setattr__(self, 'congestion', _member(Congestion, self.congestion))
        if self.priority is not None:
            object.__setattr__(self, 'priority', _member(Priority, self.priority))

    @property
    def congestion_control(self) -> Congestion:
        """What its publishers do on a full link: ``congestion`` if given, else as rmw_zenoh
        chooses: BLOCK for reliable keep-all (every message must arrive), DROP otherwise (a
        keep-last reader wants the newest; the writer never waits for a slow reader). Large
        messages under DROP never cross a link slower than they come whole: a router on the
        way turns them to BLOCK_FIRST (``zros router`` does, docs/connecting.md), or the
        publisher asks for ``congestion=BLOCK_FIRST`` itself."""
        if self.congestion is not None:
            return self.congestion
        return Congestion.BLOCK if self.reliable and self.keep_all else Congestion.DROP

    def priority_for(self, topic: str, type_name: str) -> tuple[Priority, bool]:
        """The priority and express flag of a publisher of ``type_name`` on ``topic``: the
        QoS's own, else :func:`default_priority`, express for INTERACTIVE_HIGH and above
        (small urgent messages skip batching) except on topics that come in bursts (actions'
        feedback and status, ``BURSTY_TOPICS``)."""
        priority = self.priority or default_priority(topic, type_name)
        if self.express is not None:
            return priority, self.express
        bursty = '/_action/' in topic or '/' + topic.rsplit('/', 1)[-1] in BURSTY_TOPICS
        return priority, priority <= Priority.INTERACTIVE_HIGH and not bursty

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

    def with_(self, **changes: Unpack[QoSChanges]) -> QoS:
        """A copy with some policies changed."""
        return replace(self, **changes)

    def __str__(self) -> str:
        history = 'keep all' if self.keep_all else f'keep last {self.depth}'
        text = f'{self.reliability.name.lower()}, {self.durability.name.lower()}, {history}'
        if self.lifespan is not None:
            text += f', lifespan {self.lifespan:g} s'
        if self.congestion is not None:
            text += f', {self.congestion.value}'
        if self.priority is not None:
            text += f', priority {self.priority.name.lower()}'
        if self.express:
            text += ', express'
        return text


_E = TypeVar('_E', Congestion, Priority)


def _member(kind: type[_E], value: object) -> _E:
    """``value`` as a member of ``kind``: a member, its name (any case) or its value."""
    if isinstance(value, kind):
        return value
    text = str(value)
    if text.upper() in kind.__members__:
        return kind[text.upper()]
    for member in kind:
        if str(member.value) == text.lower():
            return member
    names = ', '.join(m.name.lower() for m in kind)
    raise ValueError(f'unknown {kind.__name__.lower()} {value!r}; one of: {names}')


#: types whose messages are bulk data, sent after everything else (``Priority.DATA_LOW``)
BULK_TYPES = frozenset({
    'sensor_msgs/msg/Image', 'sensor_msgs/msg/CompressedImage', 'sensor_msgs/msg/PointCloud2',
    'sensor_msgs/msg/PointCloud', 'nav_msgs/msg/OccupancyGrid', 'map_msgs/msg/OccupancyGridUpdate',
    'foxglove_msgs/msg/CompressedVideo', 'foxglove_msgs/msg/RawImage',
    'foxglove_msgs/msg/CompressedImage', 'foxglove_msgs/msg/PointCloud',
    'ffmpeg_image_transport_msgs/msg/FFMPEGPacket', 'theora_image_transport/msg/Packet',
    'octomap_msgs/msg/Octomap', 'grid_map_msgs/msg/GridMap',
})  # fmt: skip
#: topics that steer, locate or explain the robot, sent first (``Priority.INTERACTIVE_HIGH``)
URGENT_TOPICS = frozenset({
    '/tf', '/tf_static', '/cmd_vel', '/rosout', '/parameter_events', '/joy', '/estop',
    '/e_stop', '/emergency_stop',
})  # fmt: skip
#: urgent topics whose messages come in bursts (a goal's feedback in a loop, log lines, a
#: parameter set): batched, not express. An express message takes a transmission batch of its
#: own and a link queues 2 per priority, so under DROP a burst the link's thread has not sent
#: yet loses all but 2 (a loaded machine lost 7 of 9 feedback messages); batched, a burst of
#: small messages shares one batch.
BURSTY_TOPICS = frozenset({'/rosout', '/parameter_events'})
#: services, actions and parameters: their requests, and so their replies (Zenoh replies at
#: the priority of the query), as urgent topics
SERVICE_PRIORITY = Priority.INTERACTIVE_HIGH


def default_priority(topic: str, type_name: str) -> Priority:
    """The Zenoh priority of a publisher whose QoS names none: INTERACTIVE_HIGH for the
    urgent topics (also in a namespace: ``/robot1/cmd_vel``) and actions' feedback and status,
    DATA_LOW for bulk types, DATA (Zenoh's default) for the rest."""
    if '/_action/' in topic or '/' + topic.rsplit('/', 1)[-1] in URGENT_TOPICS:
        return Priority.INTERACTIVE_HIGH
    if type_name in BULK_TYPES:
        return Priority.DATA_LOW
    return Priority.DATA


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
