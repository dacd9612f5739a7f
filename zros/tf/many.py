"""Many stamps at once: an edge sampled for a whole array of stamps, and chains composed.

A transform here is either one constant (a :data:`Pose7` of floats: a static edge, or what
static edges compose to) or arrays ``(translations (N, 3), rotations (N, 4))``. Constants
compose on floats and meet arrays through a 3x3 rotation matrix and a 4x4 quaternion product
matrix, so a chain of static edges costs nothing per stamp. An edge's slerp is prepared per
segment between two samples (angle and its sine), so each stamp costs two sines.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from zros.tf.quaternions import Pose7, compose, invert, multiply, rotate, rotation_matrix

if TYPE_CHECKING:
    from zros.tf.quaternions import Floats, Mask, Stamps

Arrays = tuple['Floats', 'Floats']
Many = Pose7 | Arrays


def sample(static: bool, stamps: Stamps, rows: Floats, times: Stamps) -> tuple[Many, Mask | None]:
    """One edge at every stamp of ``times``, and which stamps its data covers (None: all)."""
    if static:
        return _pose(rows[0]), None
    count = len(stamps)
    if count == 1:
        return _pose(rows[0]), times == stamps[0]
    covered = (times >= stamps[0]) & (times <= stamps[-1])
    segment = np.searchsorted(stamps, times, side='right')
    segment -= 1
    np.clip(segment, 0, count - 2, out=segment)
    # what interpolation needs per segment: prepared once for every segment when the stamps
    # outnumber them, else only for the segments asked (a few stamps in a long recording)
    if len(times) >= count - 1:
        used = segment
        starts, spans = stamps[:-1], np.diff(stamps)
        offsets, steps = rows[:-1], np.diff(rows[:, :3], axis=0)
        q0, q1 = rows[:-1, 3:], rows[1:, 3:].copy()
    else:
        used = np.arange(len(times))
        starts, offsets = stamps[segment], rows[segment]
        spans, steps = stamps[segment + 1] - starts, rows[segment + 1, :3] - offsets[:, :3]
        q0, q1 = offsets[:, 3:], rows[segment + 1, 3:]
    ratio = (times - starts[used]) / spans[used].astype(np.float64)
    np.clip(ratio, 0.0, 1.0, out=ratio)
    translations = offsets[used, :3]
    translations += steps[used, :3] * ratio[:, None]
    q1[np.einsum('ij,ij->i', q0, q1) < 0.0] *= -1.0  # the shorter arc
    angle = 2.0 * np.arctan2(np.linalg.norm(q0 - q1, axis=1), np.linalg.norm(q0 + q1, axis=1))
    sine = np.sin(angle)
    small = sine < 1e-12
    inverse = np.divide(1.0, sine, out=np.zeros_like(sine), where=~small)
    a = angle[used]
    w0 = np.sin((1.0 - ratio) * a)
    w0 *= inverse[used]
    w1 = np.sin(ratio * a)
    w1 *= inverse[used]
    near = small[used]
    if near.any():  # (almost) the same rotation at both ends: a plain lerp is exact enough
        w0[near] = 1.0 - ratio[near]
        w1[near] = ratio[near]
    rotations = q0[used] * w0[:, None]
    rotations += q1[used] * w1[:, None]
    return (translations, rotations), covered


def _pose(row: Floats) -> Pose7:
    x, y, z, qx, qy, qz, qw = row.tolist()
    return (x, y, z, qx, qy, qz, qw)


def compose_many(a: Many, b: Many) -> Many:
    """``a * b``, for constants and arrays alike."""
    if len(a) == 7:
        if len(b) == 7:
            return compose(a, b)
        bt, bq = b
        rotation = rotation_matrix(a[3:])
        return bt @ rotation.T + np.asarray(a[:3]), bq @ _left(a[3:]).T
    at, aq = a
    if len(b) == 7:
        moved = rotate(aq, np.asarray(b[:3])[None, :])
        return at + moved, aq @ _right(b[3:]).T
    bt, bq = b
    return at + rotate(aq, bt), multiply(aq, bq)


def invert_many(a: Many) -> Many:
    """The inverse, for a constant or arrays."""
    if len(a) == 7:
        return invert(a)
    t, q = a
    conjugate = q * np.array([-1.0, -1.0, -1.0, 1.0])
    return -rotate(conjugate, t), conjugate


def _left(p: tuple[float, float, float, float]) -> Floats:
    """The matrix of ``q -> p * q`` on ``(x, y, z, w)`` vectors."""
    x, y, z, w = p
    return np.array([[w, -z, y, x], [z, w, -x, y], [-y, x, w, z], [-x, -y, -z, w]])


def _right(p: tuple[float, float, float, float]) -> Floats:
    """The matrix of ``q -> q * p`` on ``(x, y, z, w)`` vectors."""
    x, y, z, w = p
    return np.array([[w, z, -y, x], [-z, w, x, y], [y, -x, w, z], [-x, -y, -z, w]])
