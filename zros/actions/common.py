"""What action servers and clients share: goal states, cancel codes, ids and types.

Through the bridge an action ``/fibonacci`` is three services and two topics under
``fibonacci/_action/``: ``send_goal``, ``cancel_goal``, ``get_result``, ``feedback`` and
``status`` (transient local), announced by one AS or AC token for the action itself.
"""

from __future__ import annotations

import enum
import os
import uuid

from zros.cdr import Message, TypeRegistry
from zros.cdr.interfaces import ActionType
from zros.runtime.clock import Time
from zros.services.errors import interface_type

PARTS = ('send_goal', 'cancel_goal', 'get_result', 'feedback', 'status')


class GoalStatus(enum.IntEnum):
    """The states of a goal (``action_msgs/msg/GoalStatus``)."""

    UNKNOWN = 0
    ACCEPTED = 1
    EXECUTING = 2
    CANCELING = 3
    SUCCEEDED = 4
    CANCELED = 5
    ABORTED = 6

    @property
    def terminal(self) -> bool:
        """Whether the goal has ended: succeeded, canceled or aborted."""
        return self in (GoalStatus.SUCCEEDED, GoalStatus.CANCELED, GoalStatus.ABORTED)

    @property
    def active(self) -> bool:
        """Whether the goal still runs: accepted, executing or canceling."""
        return self in (GoalStatus.ACCEPTED, GoalStatus.EXECUTING, GoalStatus.CANCELING)


class CancelReturn(enum.IntEnum):
    """The return codes of ``action_msgs/srv/CancelGoal``."""

    NONE = 0
    REJECTED = 1
    UNKNOWN_GOAL_ID = 2
    GOAL_TERMINATED = 3


class GoalResponse(enum.Enum):
    """What a ``goal_callback`` returns (``True``/``False`` work too)."""

    REJECT = 0
    ACCEPT = 1


class CancelResponse(enum.Enum):
    """What a ``cancel_callback`` returns (``True``/``False`` work too)."""

    REJECT = 0
    ACCEPT = 1


def action_type(registry: TypeRegistry, name: str | ActionType) -> ActionType:
    """The action type of a name (``pkg/action/Name`` or ``pkg/Name``) or an ActionType."""
    return interface_type(registry, name, ActionType, 'an action type')


def new_goal_id() -> bytes:
    """A random 16-byte goal id (a version 4 UUID, as rclpy makes them)."""
    return uuid.UUID(bytes=os.urandom(16), version=4).bytes


def goal_id_of(uuid_message: Message) -> bytes:
    """The 16 bytes of a ``unique_identifier_msgs/msg/UUID``."""
    return bytes(uuid_message.uuid)


def accepted(answer: object) -> bool:
    """Whether a goal or cancel callback's answer means yes."""
    if isinstance(answer, (GoalResponse, CancelResponse)):
        return answer in (GoalResponse.ACCEPT, CancelResponse.ACCEPT)
    if isinstance(answer, bool):
        return answer
    raise TypeError(f'expected GoalResponse/CancelResponse or a bool, got {answer!r}')


class GoalHandle:
    """What both sides know of a goal: its id, when the server accepted it, its state (each
    side keeps the state its own way)."""

    def __init__(self, goal_id: bytes, stamp: Time | None) -> None:
        self.goal_id = goal_id
        self.stamp = stamp  #: when the server accepted it (None until known)

    @property
    def goal_uuid(self) -> uuid.UUID:
        """The goal's id as a UUID."""
        return uuid.UUID(bytes=self.goal_id)

    @property
    def status(self) -> GoalStatus:
        """The goal's current state."""
        raise NotImplementedError
