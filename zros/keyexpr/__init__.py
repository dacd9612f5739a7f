"""ROS names to Zenoh key expressions and liveliness tokens, per wire scheme (pure functions)."""

from zros.keyexpr.bridge import EntityToken, TokenQoS
from zros.keyexpr.kinds import EntityKind, TokenError
from zros.keyexpr.names import InvalidNameError, Remapping, expand, parse_ros_args

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
