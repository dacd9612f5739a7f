"""Frames: tf2's buffer, listener and broadcasters without ROS, live or over whole recordings.

>>> from zros.tf import Buffer, TransformListener                 # doctest: +SKIP
>>> buffer = Buffer()
>>> listener = TransformListener(buffer, node)
>>> t = buffer.lookup_transform('map', 'base_link', 0, timeout=1.0)

Names follow ``tf2_ros``: rclpy code ports by changing its imports. For recordings,
``Buffer.from_bag(path)`` holds every transform and ``lookup_transforms`` answers thousands
of stamps at numpy speed; :func:`trajectory` gives a frame's path as columns.
"""

from __future__ import annotations

from zros.tf.broadcasters import StaticTransformBroadcaster, TransformBroadcaster
from zros.tf.buffer import Buffer
from zros.tf.errors import (
    ConnectivityException,
    ExtrapolationException,
    InvalidArgumentException,
    LookupException,
    TimeoutException,
    TransformException,
)
from zros.tf.listener import StaticTransformListener, TransformListener
from zros.tf.recording import trajectory
from zros.tf.report import EdgeInfo

__all__ = [
    'Buffer',
    'ConnectivityException',
    'EdgeInfo',
    'ExtrapolationException',
    'InvalidArgumentException',
    'LookupException',
    'StaticTransformBroadcaster',
    'StaticTransformListener',
    'TimeoutException',
    'TransformBroadcaster',
    'TransformException',
    'TransformListener',
    'trajectory',
]
