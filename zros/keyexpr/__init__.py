"""ROS names to Zenoh key expressions and liveliness tokens, per wire scheme (pure functions)."""

from zros.keyexpr.bridge import EntityToken, TokenQoS
from zros.keyexpr.errors import InvalidNameError, TokenError
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.names import Remapping, expand, parse_ros_args

__all__ = [
    'EntityKind',
    'EntityToken',
    'InvalidNameError',
    'Remapping',
    'TokenError',
    'TokenQoS',
    'expand',
    'parse_ros_args',
]
