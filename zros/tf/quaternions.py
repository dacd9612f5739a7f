"""Rigid transforms as a translation and a unit quaternion ``(x, y, z, w)``, as ROS writes them.

Two forms of each operation: on Python floats (one transform: a tuple of 7 floats is faster
than numpy for one) and on numpy arrays of shape ``(N, 3)`` / ``(N, 4)`` (thousands at once).
Translations interpolate linearly, rotations by slerp along the shorter arc, as tf2 does.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from typing import TypeAlias

    import numpy.typing as npt

    Floats: TypeAlias = npt.NDArray[np.float64]  #: translations, rotations, rows of poses
    Stamps: TypeAlias = npt.NDArray[np.int64]  #: instants in nanoseconds
    Mask: TypeAlias = npt.NDArray[np.bool_]  #: which stamps something covers

#: a transform as ``(tx, ty, tz, qx, qy, qz, qw)``
Pose7 = tuple[float, float, float, float, float, float, float]

IDENTITY: Pose7 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


# --- one transform (floats) --------------------------------------------------------------------


def compose(a: Pose7, b: Pose7) -> Pose7:
    """``a * b``: the transform ``b`` expressed through ``a`` (T_ab composed with T_bc is T_ac)."""
    ax, ay, az, qx, qy, qz, qw = a
    bx, by, bz, rx, ry, rz, rw = b
    # rotate b's translation by a's rotation: v + 2 w (q x v) + 2 q x (q x v)
    cx = qy * bz - qz * by
    cy = qz * bx - qx * bz
    cz = qx * by - qy * bx
    dx = qy * cz - qz * cy
    dy = qz * cx - qx * cz
    dz = qx * cy - qy * cx
    return (
        ax + bx + 2.0 * (qw * cx + dx),
        ay + by + 2.0 * (qw * cy + dy),
        az + bz + 2.0 * (qw * cz + dz),
        qw * rx + qx * rw + qy * rz - qz * ry,
        qw * ry - qx * rz + qy * rw + qz * rx,
        qw * rz + qx * ry - qy * rx + qz * rw,
        qw * rw - qx * rx - qy * ry - qz * rz,
    )


def invert(a: Pose7) -> Pose7:
    """The inverse transform (T_ab -> T_ba)."""
    x, y, z, qx, qy, qz, qw = a
    inverse_rotation: Pose7 = (0.0, 0.0, 0.0, -qx, -qy, -qz, qw)
    moved = compose(inverse_rotation, (x, y, z, 0.0, 0.0, 0.0, 1.0))
    return (-moved[0], -moved[1], -moved[2], -qx, -qy, -qz, qw)


def interpolate(a: Pose7, b: Pose7, ratio: float) -> Pose7:
    """The transform ``ratio`` of the way from ``a`` to ``b`` (lerp and slerp)."""
    ax, ay, az, qx, qy, qz, qw = a
    bx, by, bz, rx, ry, rz, rw = b
    if qx * rx + qy * ry + qz * rz + qw * rw < 0.0:  # the shorter arc
        rx, ry, rz, rw = -rx, -ry, -rz, -rw
    dx, dy, dz, dw = qx - rx, qy - ry, qz - rz, qw - rw
    sx, sy, sz, sw = qx + rx, qy + ry, qz + rz, qw + rw
    # the angle between the two, stable near 0 (arccos of the dot product is not)
    angle = 2.0 * math.atan2(
        math.sqrt(dx * dx + dy * dy + dz * dz + dw * dw),
        math.sqrt(sx * sx + sy * sy + sz * sz + sw * sw),
    )
    sine = math.sin(angle)
    if sine < 1e-12:
        w0, w1 = 1.0 - ratio, ratio
    else:
        w0 = math.sin((1.0 - ratio) * angle) / sine
        w1 = math.sin(ratio * angle) / sine
    x, y, z, w = w0 * qx + w1 * rx, w0 * qy + w1 * ry, w0 * qz + w1 * rz, w0 * qw + w1 * rw
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    return (
        ax + (bx - ax) * ratio,
        ay + (by - ay) * ratio,
        az + (bz - az) * ratio,
        x / norm,
        y / norm,
        z / norm,
        w / norm,
    )


def rotation_matrix(q: tuple[float, float, float, float]) -> Floats:
    """The 3x3 rotation matrix of a unit quaternion ``(x, y, z, w)``."""
    matrix: Floats = rotation_matrices(np.asarray(q, dtype=np.float64)[None, :])[0]
    return matrix


def euler_from_quaternion(q: tuple[float, float, float, float]) -> tuple[float, float, float]:
    """Roll, pitch, yaw (radians; fixed axes x, y, z as tf2's ``getRPY``)."""
    x, y, z, w = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


# --- many transforms (numpy) -------------------------------------------------------------------


def multiply(q: Floats, r: Floats) -> Floats:
    """Hamilton products ``q * r`` of quaternion arrays ``(..., 4)`` (broadcasting)."""
    qx, qy, qz, qw = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rx, ry, rz, rw = r[..., 0], r[..., 1], r[..., 2], r[..., 3]
    return np.stack(
        (
            qw * rx + qx * rw + qy * rz - qz * ry,
            qw * ry - qx * rz + qy * rw + qz * rx,
            qw * rz + qx * ry - qy * rx + qz * rw,
            qw * rw - qx * rx - qy * ry - qz * rz,
        ),
        axis=-1,
    )


def rotate(q: Floats, v: Floats) -> Floats:
    """Vectors ``v (..., 3)`` rotated by unit quaternions ``q (..., 4)`` (broadcasting)."""
    u = q[..., :3]
    c = np.cross(u, v)
    return v + 2.0 * (q[..., 3:4] * c + np.cross(u, c))


def compose_arrays(t1: Floats, q1: Floats, t2: Floats, q2: Floats) -> tuple[Floats, Floats]:
    """``(t1, q1) * (t2, q2)`` for arrays of transforms (broadcasting)."""
    return t1 + rotate(q1, t2), multiply(q1, q2)


def slerp(q0: Floats, q1: Floats, ratio: Floats) -> Floats:
    """Unit quaternions ``ratio`` of the way from ``q0`` to ``q1`` along the shorter arc
    (``(N, 4)``, ``(N, 4)``, ``(N,)``)."""
    sign = np.where(np.einsum('ij,ij->i', q0, q1) < 0.0, -1.0, 1.0)[:, None]
    q1 = q1 * sign
    angle = 2.0 * np.arctan2(np.linalg.norm(q0 - q1, axis=1), np.linalg.norm(q0 + q1, axis=1))
    sine = np.sin(angle)
    small = sine < 1e-12
    safe = np.where(small, 1.0, sine)
    w0 = np.where(small, 1.0 - ratio, np.sin((1.0 - ratio) * angle) / safe)
    w1 = np.where(small, ratio, np.sin(ratio * angle) / safe)
    out = q0 * w0[:, None] + q1 * w1[:, None]
    out /= np.linalg.norm(out, axis=1)[:, None]
    result: Floats = out
    return result


def rotation_matrices(q: Floats) -> Floats:
    """Rotation matrices ``(N, 3, 3)`` of unit quaternions ``(N, 4)`` as ``(x, y, z, w)``."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    matrices: Floats = np.stack(
        (
            np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)), -1),
            np.stack((2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)), -1),
            np.stack((2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)), -1),
        ),
        axis=1,
    )
    return matrices
