"""Transforms refused before they reach the tree, named and worded as tf2 names them.

Each refusal is counted by code and logged once per (code, sender, frame): a publisher that
sends the same bad transform at 100 Hz costs one log line, not a flood.
"""

from __future__ import annotations

import logging
import math
import threading
from collections import Counter
from collections.abc import Hashable

from zros.tf.quaternions import Pose7

_log = logging.getLogger('zros.tf')

NO_FRAME_ID = 'TF_NO_FRAME_ID'
NO_CHILD_FRAME_ID = 'TF_NO_CHILD_FRAME_ID'
SELF_TRANSFORM = 'TF_SELF_TRANSFORM'
NAN_INPUT = 'TF_NAN_INPUT'
DENORMALIZED_QUATERNION = 'TF_DENORMALIZED_QUATERNION'
LOOP = 'TF_LOOP'
TWO_PARENTS = 'TF_TWO_PARENTS'
TOO_MANY_FRAMES = 'TF_TOO_MANY_FRAMES'

#: (code, sender, frame) triples told apart; past this, refusals are only counted
MAX_TOLD = 4096

#: who sent a transform: a name, or an object whose ``str()`` names it when it is shown (the
#: listener's senders, named by the graph, which may learn of a publisher after its data)
Authority = Hashable


def check(child: str, parent: str, pose: Pose7, authority: Authority) -> tuple[str, str] | None:
    """Why tf2 would ignore this transform, as ``(code, message)``; None when it is fine."""
    if not child:
        return NO_CHILD_FRAME_ID, (
            f'TF_NO_CHILD_FRAME_ID: Ignoring transform from authority "{authority}" because '
            'child_frame_id not set'
        )
    if not parent:
        return NO_FRAME_ID, (
            f'TF_NO_FRAME_ID: Ignoring transform with child_frame_id "{child}" from authority '
            f'"{authority}" because frame_id not set'
        )
    if child == parent:
        return SELF_TRANSFORM, (
            f'TF_SELF_TRANSFORM: Ignoring transform from authority "{authority}" with frame_id '
            f'and child_frame_id "{child}" because they are the same'
        )
    if not all(map(math.isfinite, pose)):
        numbers = ' '.join(f'{v:f}' for v in pose)
        return NAN_INPUT, (
            f'TF_NAN_INPUT: Ignoring transform for child_frame_id "{child}" from authority '
            f'"{authority}" because of a nan value in the transform ({numbers})'
        )
    qx, qy, qz, qw = pose[3:]
    if abs(qx * qx + qy * qy + qz * qz + qw * qw - 1.0) > 10e-6:
        return DENORMALIZED_QUATERNION, (
            f'TF_DENORMALIZED_QUATERNION: Ignoring transform for child_frame_id "{child}" from '
            f'authority "{authority}" because of an invalid quaternion in the transform '
            f'({qx:f} {qy:f} {qz:f} {qw:f})'
        )
    return None


def normalized(pose: Pose7) -> Pose7:
    """The pose with its quaternion scaled to length 1 (tf2 stores it so)."""
    x, y, z, qx, qy, qz, qw = pose
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    return (x, y, z, qx / norm, qy / norm, qz / norm, qw / norm)


class Rejections:
    """Refused transforms: counted by code, logged once per (code, sender, frame)."""

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self._told: set[tuple[str, Authority, str]] = set()
        self._lock = threading.Lock()

    def report(self, code: str, authority: Authority, frame: str, message: str) -> None:
        """Count one refusal; log ``message`` the first time this sender does it."""
        key = (code, authority, frame)
        with self._lock:
            self.counts[code] += 1
            if key in self._told or len(self._told) >= MAX_TOLD:
                return
            self._told.add(key)
        _log.warning('%s', message)
