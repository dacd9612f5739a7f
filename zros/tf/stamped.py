"""Stamped geometry messages carried into another frame (tf2_geometry_msgs's ``do_transform_*``)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from zros.cdr import Message
from zros.tf.errors import InvalidArgumentException
from zros.tf.quaternions import Pose7, compose, rotation_matrix


def _pose_of(transform: Message) -> Pose7:
    t = transform.transform.translation
    q = transform.transform.rotation
    return (t.x, t.y, t.z, q.x, q.y, q.z, q.w)


def _move_point(point: Message, pose: Pose7, translate: bool) -> None:
    x, y, z, *_ = compose((0.0, 0.0, 0.0, *pose[3:]), (point.x, point.y, point.z, 0, 0, 0, 1))
    if translate:
        x, y, z = x + pose[0], y + pose[1], z + pose[2]
    point.x, point.y, point.z = x, y, z


def _move_pose(pose_msg: Message, pose: Pose7) -> None:
    p, o = pose_msg.position, pose_msg.orientation
    moved = compose(pose, (p.x, p.y, p.z, o.x, o.y, o.z, o.w))
    p.x, p.y, p.z = moved[:3]
    o.x, o.y, o.z, o.w = moved[3:]


def _point(out: Message, pose: Pose7) -> None:
    _move_point(out.point, pose, translate=True)


def _vector(out: Message, pose: Pose7) -> None:
    _move_point(out.vector, pose, translate=False)


def _pose(out: Message, pose: Pose7) -> None:
    _move_pose(out.pose, pose)


def _pose_with_covariance(out: Message, pose: Pose7) -> None:
    _move_pose(out.pose.pose, pose)
    rotation = rotation_matrix(pose[3:])
    both = np.zeros((6, 6))
    both[:3, :3] = rotation
    both[3:, 3:] = rotation
    covariance = np.asarray(out.pose.covariance, dtype=np.float64).reshape(6, 6)
    out.pose.covariance = (both @ covariance @ both.T).reshape(36)


_MOVERS: dict[str, Callable[[Message, Pose7], None]] = {
    'geometry_msgs/msg/PointStamped': _point,
    'geometry_msgs/msg/Vector3Stamped': _vector,
    'geometry_msgs/msg/PoseStamped': _pose,
    'geometry_msgs/msg/PoseWithCovarianceStamped': _pose_with_covariance,
}


def transform_stamped(obj: Message, transform: Message) -> Message:
    """A copy of ``obj`` carried by ``transform`` (a ``TransformStamped``), with its header:
    the target frame and the stamp the transform holds (tf2_geometry_msgs's way: an ``obj``
    stamped 0, the latest, comes back with the time actually used)."""
    mover = _MOVERS.get(getattr(obj, '__msgtype__', ''))
    if mover is None:
        raise InvalidArgumentException(
            f'cannot transform a {type(obj).__name__}: zros.tf transforms '
            + ', '.join(name.rsplit('/', 1)[1] for name in _MOVERS)
        )
    out = obj.copy()
    mover(out, _pose_of(transform))
    out.header = transform.header.copy()
    return out
