"""ROS names to Zenoh key expressions and liveliness tokens, per wire scheme (pure functions)."""

from zros.keyexpr.bridge import EntityKind, EntityToken, TokenError, TokenQoS
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
