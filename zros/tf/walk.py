"""Walking a chain of edges: at one stamp on floats, or at many on numpy arrays; the newest
instant a chain covers, and the error when a stamp lies outside it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from zros.tf.cache import EdgeCache, OutOfRange
from zros.tf.errors import ExtrapolationException
from zros.tf.many import Many, compose_many, invert_many, sample
from zros.tf.quaternions import IDENTITY, Pose7, compose
from zros.tf.times import format_time
from zros.tf.tree import Chain

if TYPE_CHECKING:
    from zros.tf.quaternions import Floats, Mask, Stamps


def through(steps: tuple[EdgeCache | Pose7, ...], stamp: int) -> Pose7:
    """The chain's steps at ``stamp`` composed (the top of the walk in its bottom)."""
    pose = IDENTITY
    for number, step in enumerate(steps):
        here = step if isinstance(step, tuple) else step.at(stamp)
        pose = here if number == 0 else compose(here, pose)
    return pose


def latest_common(chain: Chain) -> int:
    """The newest instant at which every moving edge of the chain has data (0: none moves)."""
    moving = chain.moving
    if not moving:
        return 0
    return min(edge.newest for _, edge in moving)


def extrapolation(chain: Chain, stamp: int, exc: OutOfRange) -> ExtrapolationException:
    """tf2's extrapolation error, with the span the whole chain covers."""
    route = f'when looking up transform from frame [{chain.source}] to frame [{chain.target}]'
    if exc.side == 'only':
        head = (
            f'Lookup would require extrapolation at time {format_time(stamp)}, but only time '
            f'{format_time(exc.oldest)} is in the buffer, {route}'
        )
    elif exc.side == 'past':
        head = (
            'Lookup would require extrapolation into the past. Requested time '
            f'{format_time(stamp)} but the earliest data is at time {format_time(exc.oldest)}, '
            f'{route}'
        )
    else:
        head = (
            'Lookup would require extrapolation into the future. Requested time '
            f'{format_time(stamp)} but the latest data is at time {format_time(exc.newest)}, '
            f'{route}'
        )
    moving = chain.moving
    low = max(edge.oldest for _, edge in moving)
    high = min(edge.newest for _, edge in moving)
    if low <= high:
        covered = f'the chain has data from {format_time(low)} to {format_time(high)}'
    else:
        spans = ', '.join(
            f'{edge.parent} -> {child} [{format_time(edge.oldest)}, {format_time(edge.newest)}]'
            for child, edge in moving
        )
        covered = f'no instant is covered by every moving edge of the chain ({spans})'
    return ExtrapolationException(f'{head}; {covered}')


def edge_data(edge: EdgeCache, copy: bool) -> tuple[Stamps, Floats]:
    """An edge's stamps and rows, copied when the edge may change under a reader."""
    stamps = edge.stamps
    rows = edge.rows
    if copy:
        return stamps.copy(), rows.copy()
    return stamps, rows


def sample_chain(
    chain: Chain,
    data: dict[EdgeCache, tuple[Stamps, Floats]],
    stamps: Stamps,
) -> tuple[Floats, Floats, Mask]:
    """T_target_source of ``chain`` at every stamp, from each edge's ``data`` (stamps, rows):
    ``(translations (N, 3), rotations (N, 4), which stamps every edge covers)``."""
    count = len(stamps)
    valid = np.ones(count, dtype=bool)

    def walk(edges: tuple[tuple[str, EdgeCache], ...]) -> Many:
        pose: Many = IDENTITY
        for _, edge in edges:
            edge_stamps, rows = data[edge]
            sampled, covered = sample(edge.static, edge_stamps, rows, stamps)
            if covered is not None:
                valid[:] &= covered
            pose = compose_many(sampled, pose)
        return pose

    up = walk(chain.up)
    pose = compose_many(invert_many(walk(chain.down)), up) if chain.down else up
    if len(pose) == 7:
        t = np.array(np.broadcast_to(np.asarray(pose[:3]), (count, 3)))
        q = np.array(np.broadcast_to(np.asarray(pose[3:]), (count, 4)))
    else:
        t, q = pose
    return t, q, valid
