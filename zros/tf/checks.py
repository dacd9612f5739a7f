"""Transforms refused before they reach the tree, named and worded as tf2 names them.

Each refusal is counted by code and logged once per (code, sender, frame), and a sender past
the frame limit once: a publisher that sends the same bad transform at 100 Hz, or 20,000 new
frame names, costs one log line, not a flood.
"""

from __future__ import annotations

import logging
import math
import threading
from collections import Counter
from collections.abc import Hashable

from zros.tf.quaternions import Pose7
from zros.tf.times import format_time

_log = logging.getLogger('zros.tf')

NO_FRAME_ID = 'TF_NO_FRAME_ID'
NO_CHILD_FRAME_ID = 'TF_NO_CHILD_FRAME_ID'
SELF_TRANSFORM = 'TF_SELF_TRANSFORM'
NAN_INPUT = 'TF_NAN_INPUT'
DENORMALIZED_QUATERNION = 'TF_DENORMALIZED_QUATERNION'
LOOP = 'TF_LOOP'
TOO_MANY_FRAMES = 'TF_TOO_MANY_FRAMES'
OLD_DATA = 'TF_OLD_DATA'
REPEATED_DATA = 'TF_REPEATED_DATA'

#: how far from 1 a quaternion's squared length may be; tf2's QUATERNION_NORMALIZATION_TOLERANCE
#: (rounded constants such as 0.7071 pass; the quaternion is normalised)
QUATERNION_TOLERANCE = 10e-3

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
    if abs(qx * qx + qy * qy + qz * qz + qw * qw - 1.0) > QUATERNION_TOLERANCE:
        return DENORMALIZED_QUATERNION, (
            f'TF_DENORMALIZED_QUATERNION: Ignoring transform for child_frame_id "{child}" from '
            f'authority "{authority}" because of an invalid quaternion in the transform '
            f'({qx:f} {qy:f} {qz:f} {qw:f})'
        )
    return None


def old_data(child: str, stamp: int, authority: Authority, kept: int, newest: int) -> str:
    """A transform older than what the edge keeps before its newest one."""
    return (
        f'TF_OLD_DATA ignoring data from the past for frame {child} at time '
        f'{format_time(stamp)} according to authority {authority}: the buffer keeps '
        f'{format_time(kept)} s before its newest transform, at {format_time(newest)}'
    )


def repeated_data(child: str, parent: str, stamp: int, authority: Authority) -> str:
    """A transform at a stamp the edge already holds."""
    return (
        f'TF_REPEATED_DATA ignoring data with redundant timestamp for frame {child} '
        f'(parent {parent}) at time {format_time(stamp)} according to authority {authority}'
    )


def repeated_batch(count: int, child: str, parent: str, authority: Authority) -> str:
    """``count`` transforms of a recording's batch at stamps the edge already holds."""
    return (
        f'TF_REPEATED_DATA ignoring {count} transforms with redundant timestamps for '
        f'frame {child} (parent {parent}) according to authority {authority}'
    )


def loop(child: str, parent: str, authority: Authority, cycle: str) -> str:
    """A transform that would close a loop in the tree."""
    return (
        f'TF_LOOP: Ignoring transform for child_frame_id "{child}" from authority '
        f'"{authority}" with frame_id "{parent}": it would close a loop ({cycle})'
    )


def too_many_frames(child: str, authority: Authority, limit: int) -> str:
    """A new frame past the buffer's limit."""
    return (
        f'TF_TOO_MANY_FRAMES: Ignoring transform for child_frame_id "{child}" from '
        f'authority "{authority}": the buffer holds {limit} frames already'
    )


def normalized(pose: Pose7) -> Pose7:
    """The pose with its quaternion scaled to length 1 (tf2 stores it so)."""
    x, y, z, qx, qy, qz, qw = pose
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    return (x, y, z, qx / norm, qy / norm, qz / norm, qw / norm)


class Rejections:
    """Refused transforms: counted by code, logged once per (code, sender, frame) (per (code,
    sender) for the frame limit)."""

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self._told: set[tuple[str, Authority, str]] = set()
        self._lock = threading.Lock()

    def report(self, code: str, authority: Authority, frame: str, message: str) -> None:
        """Count one refusal; log ``message`` the first time this sender does it."""
        # a flood of new names is one fault of its sender, not one per name
        key = (code, authority, '' if code == TOO_MANY_FRAMES else frame)
        with self._lock:
            self.counts[code] += 1
            if key in self._told or len(self._told) >= MAX_TOLD:
                return
            self._told.add(key)
        _log.warning('%s', message)
