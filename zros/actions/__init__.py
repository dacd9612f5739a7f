"""ROS 2 actions through zenoh-bridge-ros2dds: servers and clients."""

from zros.actions.client import ActionClient, ClientGoalHandle
from zros.actions.common import CancelResponse, CancelReturn, GoalResponse, GoalStatus
from zros.actions.errors import ActionError, GoalRejectedError
from zros.actions.server import ActionServer
from zros.actions.server_goal import ServerGoalHandle

__all__ = [
    'ActionClient',
    'ActionError',
    'ActionServer',
    'CancelResponse',
    'CancelReturn',
    'ClientGoalHandle',
    'GoalRejectedError',
    'GoalResponse',
    'GoalStatus',
    'ServerGoalHandle',
]
