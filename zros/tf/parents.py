"""A frame whose parent changes over time (a cup on a table, then in a gripper): which parent
holds it at a stamp, as tf2 answers from its one cache per frame whose samples each name their
parent.

zros keeps one :class:`EdgeCache` per (frame, parent) instead. At a stamp, the frame hangs
from the parent of the newest sample at or before it (tf2's ``getParent``); it is interpolated
only when the next sample after the stamp has the same parent, and otherwise that newest sample
holds (tf2's ``getData``: no interpolation between two parents).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

from zros.tf.cache import EdgeCache


def edge_at(edges: Mapping[str, EdgeCache], stamp: int) -> EdgeCache:
    """The edge (by parent) that holds the frame at ``stamp``: one of ``edges``, or a one-row
    static edge with the sample that holds until the frame's next sample under another parent.
    Before or after all samples it is the nearest edge, whose ``at`` raises the
    extrapolation."""
    before: EdgeCache | None = None
    before_stamp = 0
    after: EdgeCache | None = None
    after_stamp = 0
    for edge in edges.values():
        if not len(edge):
            continue
        stamps = edge.stamps
        index = int(stamps.searchsorted(stamp, 'right'))
        if index and (before is None or stamps.item(index - 1) > before_stamp):
            before, before_stamp = edge, stamps.item(index - 1)
        if index < len(stamps) and (after is None or stamps.item(index) < after_stamp):
            after, after_stamp = edge, stamps.item(index)
    if before is None:
        if after is None:
            raise ValueError('a frame with no transforms under any parent')
        return after
    if after is None or after is before or before_stamp == stamp:
        return before
    held = EdgeCache(before.parent, static=True, max_age=None, capacity=1)
    held.insert(before_stamp, before.at(before_stamp))
    held.authority = before.authority
    return held


class EdgesAt(Mapping[str, EdgeCache]):
    """The tree's edges as they were at ``stamp``: ``current`` (each frame's newest parent),
    except the frames of ``parents`` (those that changed parent), resolved by :func:`edge_at`."""

    def __init__(
        self,
        current: Mapping[str, EdgeCache],
        parents: Mapping[str, Mapping[str, EdgeCache]],
        stamp: int,
    ) -> None:
        self._current = current
        self._parents = parents
        self._stamp = stamp

    def __getitem__(self, frame: str) -> EdgeCache:
        edges = self._parents.get(frame)
        if edges is None:
            return self._current[frame]
        return edge_at(edges, self._stamp)

    def __iter__(self) -> Iterator[str]:
        return iter(self._current)

    def __len__(self) -> int:
        return len(self._current)
