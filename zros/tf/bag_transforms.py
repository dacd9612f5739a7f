"""The transforms of a recording's tf topics, checked and grouped by edge.

Only the tf topics are read. Each transform passes tf2's checks (``zros.tf.checks``); the good
ones are grouped per (parent, child, static, sender) into arrays the buffer stores at once.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from zros.bag import Bag, BagError
from zros.tf import checks

if TYPE_CHECKING:
    from zros.tf.quaternions import Floats, Stamps

_NS = 1_000_000_000
#: how far an edge's stamps may go back, in the order recorded, before it is told (tf2_ros
#: clears its buffer at a clock jump back of 1 s)
JUMP_BACK = _NS

_log = logging.getLogger('zros.tf')


@dataclass(frozen=True)
class EdgeBatch:
    """The checked transforms of one edge from one sender: stamps (int64 ns) and ``(N, 7)``
    rows (translation, quaternion x y z w)."""

    parent: str
    child: str
    static: bool
    authority: str
    stamps: Stamps
    rows: Floats


def _is_static(topic: str) -> bool:
    return topic.rstrip('/').endswith('tf_static')


def read_transforms(
    bag: Bag | str | Path, topics: tuple[str, ...], rejections: checks.Rejections
) -> list[EdgeBatch]:
    """The transforms of ``topics`` in ``bag`` by edge; refused ones go to ``rejections``."""
    if isinstance(bag, Bag):
        return _read(bag, topics, rejections)
    with Bag(bag) as opened:
        return _read(opened, topics, rejections)


def _read(bag: Bag, topics: tuple[str, ...], rejections: checks.Rejections) -> list[EdgeBatch]:
    present = [topic for topic in topics if topic in bag.topics]
    if not present:
        raise BagError(
            bag.path,
            f'no topic {" or ".join(topics)} in the recording; it has: '
            f'{", ".join(bag.topics) or "none"}',
        )
    # (parent, child, static, authority) -> stamps, poses; checked one by one, stored at once
    batches: dict[tuple[str, str, bool, str], tuple[list[int], list[tuple[float, ...]]]] = {}
    decode = bag.types.decode_or_skip  # a damaged message is skipped and counted, as Bag does
    for raw in bag.raw_messages(present):
        topic = raw.connection.topic
        static = _is_static(topic)
        # a ROS 1 publisher's node, as view_frames names it; ROS 2 records none: the connection
        authority = raw.connection.caller_id or (
            f'{topic} (connection {raw.connection.id} of {bag.path.name})'
        )
        message = decode(raw)
        for transform in message.transforms if message is not None else ():
            header = transform.header
            parent = header.frame_id.lstrip('/')
            child = transform.child_frame_id.lstrip('/')
            t = transform.transform.translation
            q = transform.transform.rotation
            pose = (t.x, t.y, t.z, q.x, q.y, q.z, q.w)
            problem = checks.check(child, parent, pose, authority)
            if problem is not None:
                rejections.report(problem[0], authority, child, problem[1])
                continue
            key = (parent, child, static, authority)
            batch = batches.get(key)
            if batch is None:
                batch = batches[key] = ([], [])
            batch[0].append(header.stamp.sec * _NS + header.stamp.nanosec)
            batch[1].append(checks.normalized(pose))
    edges = [
        EdgeBatch(
            parent,
            child,
            static,
            authority,
            np.asarray(stamps, dtype=np.int64),
            np.asarray(poses, dtype=np.float64),
        )
        for (parent, child, static, authority), (stamps, poses) in batches.items()
    ]
    for edge in edges:
        if not edge.static:
            _tell_restart(bag, edge)
    return edges


def _tell_restart(bag: Bag, edge: EdgeBatch) -> None:
    """Warn when an edge's stamps go back in the order recorded: the recording's clock
    restarted (a simulation reset, a bag recorded while another looped), and the buffer, which
    keeps one value per stamp, merges the runs."""
    steps = np.diff(edge.stamps)
    back = np.flatnonzero(steps < -JUMP_BACK)
    if not len(back):
        return
    first = int(back[0])
    _log.warning(
        '%s: the transforms of %s (parent %s) go back %.1f s after their %d-th, %d time(s) in '
        'all: the clock restarted while recording; lookups mix the runs, stamp by stamp',
        bag.path, edge.child, edge.parent, -steps[first] / _NS, first + 1, len(back),
    )  # fmt: skip
