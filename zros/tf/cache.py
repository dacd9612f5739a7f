"""The time-sorted storage of one edge of the tree (a child frame's transforms to its parent).

Stamps are one int64 numpy array and the transforms one ``(N, 7)`` float64 array (translation,
then quaternion x y z w), both with spare room at the end: a live edge appends in time order
(amortised O(1)), drops what is older than ``max_age`` before its newest stamp, and moves its
rows back to the start once the dropped part is half of the room. A static edge holds one
transform, valid at every time.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from zros.tf.checks import Authority
from zros.tf.quaternions import Pose7, interpolate

if TYPE_CHECKING:
    from zros.tf.quaternions import Floats, Stamps

#: insert outcomes other than success, with tf2's names
OLD_DATA = 'TF_OLD_DATA'
REPEATED_DATA = 'TF_REPEATED_DATA'

_EMPTY_STAMPS = np.zeros(0, dtype=np.int64)


class OutOfRange(Exception):
    """A time this edge has no data for (``side``: 'past', 'future' or 'only')."""

    def __init__(self, side: str, oldest: int, newest: int) -> None:
        super().__init__(side)
        self.side = side
        self.oldest = oldest
        self.newest = newest


class EdgeCache:
    """The transforms of one child frame to its ``parent`` over time."""

    __slots__ = (
        '_data',
        '_end',
        '_stamps',
        '_start',
        'authority',
        'max_age',
        'max_length',
        'parent',
        'received',
        'static',
    )

    def __init__(
        self,
        parent: str,
        *,
        static: bool,
        max_age: int | None,
        max_length: int | None = None,
        capacity: int = 16,
    ) -> None:
        self.parent = parent
        self.static = static
        self.max_age = max_age  #: nanoseconds kept before the newest stamp (None: all)
        self.max_length = max_length  #: most transforms kept (None: no limit)
        self.authority: Authority = ''  #: who sent the newest transform
        self.received = 0  #: transforms accepted since the edge was made
        self._stamps = np.zeros(capacity, dtype=np.int64)
        self._data = np.zeros((capacity, 7), dtype=np.float64)
        self._start = 0
        self._end = 0

    # --- what it holds ---------------------------------------------------------------------

    def __len__(self) -> int:
        return self._end - self._start

    @property
    def stamps(self) -> Stamps:
        """The stamps held, oldest first (a view)."""
        return self._stamps[self._start : self._end]

    @property
    def rows(self) -> Floats:
        """The transforms held as ``(N, 7)`` rows (a view)."""
        return self._data[self._start : self._end]

    @property
    def oldest(self) -> int:
        """The oldest stamp held."""
        return int(self._stamps[self._start])

    @property
    def newest(self) -> int:
        """The newest stamp held."""
        return int(self._stamps[self._end - 1])

    # --- filling -----------------------------------------------------------------------------

    def insert(self, stamp: int, pose: Pose7) -> str | None:
        """Add one transform; None, or why it was refused (``OLD_DATA``, ``REPEATED_DATA``)."""
        if self.static:
            self._stamps[0] = stamp
            self._data[0] = pose
            self._start, self._end = 0, 1
            self.received += 1
            return None
        start, end = self._start, self._end
        if end > start:
            newest = int(self._stamps[end - 1])
            if stamp > newest:
                position = end
            else:
                if self.max_age is not None and stamp < newest - self.max_age:
                    return OLD_DATA
                held = self._stamps[start:end]
                position = start + int(np.searchsorted(held, stamp))
                if position < end and int(self._stamps[position]) == stamp:
                    return REPEATED_DATA
        else:
            position = end
        if end == len(self._stamps):
            self._make_room()
            position -= start - self._start
            start, end = self._start, self._end
        if position < end:  # out of order: shift the newer ones up by one
            self._stamps[position + 1 : end + 1] = self._stamps[position:end]
            self._data[position + 1 : end + 1] = self._data[position:end]
        self._stamps[position] = stamp
        self._data[position] = pose
        self._end = end + 1
        self.received += 1
        self._prune()
        return None

    def extend(self, stamps: Stamps, rows: Floats) -> int:
        """Add many transforms at once (a recording); returns how many repeated a stamp held
        (those are dropped, the first of each stamp kept)."""
        if self.static:
            if len(stamps):
                self.insert(int(stamps[-1]), tuple(rows[-1].tolist()))
            return 0
        all_stamps = np.concatenate((self.stamps, stamps))
        all_rows = np.concatenate((self.rows, rows))
        order = np.argsort(all_stamps, kind='stable')
        all_stamps, all_rows = all_stamps[order], all_rows[order]
        keep = np.ones(len(all_stamps), dtype=bool)
        keep[1:] = all_stamps[1:] != all_stamps[:-1]
        repeated = int(len(keep) - np.count_nonzero(keep))
        self._stamps = np.ascontiguousarray(all_stamps[keep])
        self._data = np.ascontiguousarray(all_rows[keep])
        self._start, self._end = 0, len(self._stamps)
        self.received += len(stamps) - repeated
        return repeated

    def _make_room(self) -> None:
        held = len(self)
        capacity = len(self._stamps)
        if held * 2 > capacity:
            capacity *= 2
        stamps = np.zeros(capacity, dtype=np.int64)
        data = np.zeros((capacity, 7), dtype=np.float64)
        stamps[:held] = self.stamps
        data[:held] = self.rows
        self._stamps, self._data = stamps, data
        self._start, self._end = 0, held

    def _prune(self) -> None:
        start, end = self._start, self._end
        if self.max_age is not None:
            cutoff = int(self._stamps[end - 1]) - self.max_age
            if int(self._stamps[start]) < cutoff:
                start += int(np.searchsorted(self._stamps[start:end], cutoff))
        if self.max_length is not None and end - start > self.max_length:
            start = end - self.max_length
        self._start = start

    # --- reading -------------------------------------------------------------------------------

    def at(self, stamp: int) -> Pose7:
        """The transform at ``stamp``, interpolated; :class:`OutOfRange` outside the data."""
        start, end = self._start, self._end
        if self.static:
            return tuple(self._data[start].tolist())
        stamps = self._stamps
        first = stamps.item(start)
        last = stamps.item(end - 1)
        if stamp >= last:
            if stamp == last:
                return tuple(self._data[end - 1].tolist())
            raise OutOfRange('only' if end - start == 1 else 'future', first, last)
        if stamp <= first:
            if stamp == first:
                return tuple(self._data[start].tolist())
            raise OutOfRange('only' if end - start == 1 else 'past', first, last)
        after = start + int(stamps[start:end].searchsorted(stamp, 'right'))
        before_stamp = stamps.item(after - 1)
        before = tuple(self._data[after - 1].tolist())
        if before_stamp == stamp:
            return before
        ratio = (stamp - before_stamp) / (stamps.item(after) - before_stamp)
        return interpolate(before, tuple(self._data[after].tolist()), ratio)

    def covers(self, stamp: int) -> bool:
        """Whether :meth:`at` has data for ``stamp``."""
        if self.static:
            return True
        return int(self._stamps[self._start]) <= stamp <= int(self._stamps[self._end - 1])


def stamps_of(cache: EdgeCache | None) -> Stamps:
    """The stamps a cache holds (none for None)."""
    return _EMPTY_STAMPS if cache is None else cache.stamps
