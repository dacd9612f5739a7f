"""The time-order merge of a recording's chunks, read one at a time in the order of their
first times (ROS 1 bags by their index or a scan, MCAP files without summary)."""

from __future__ import annotations

import heapq
from collections.abc import Iterable, Iterator
from typing import TypeVar

#: an indexed message: time, chunk position, offset in the chunk, connection id
Entry = tuple[int, int, int, int]
#: a read message: time, chunk position, rank in the chunk, connection id, data
Scanned = tuple[int, int, int, int, bytes]
_T = TypeVar('_T', Entry, Scanned)


def merged(chunks: Iterable[tuple[int, list[_T]]]) -> Iterator[_T]:
    """The items (time first) of chunks given as ``(first time, items)`` in the order of
    their first times, in time order (then file order): an item is handed on once no chunk
    still to read can hold an earlier one, so only where chunks overlap in time are items of
    several chunks held. A chunk is read when the merge reaches it."""
    pending: list[_T] = []
    for first, items in chunks:
        while pending and pending[0][0] < first:
            yield heapq.heappop(pending)
        for item in items:
            heapq.heappush(pending, item)
    while pending:
        yield heapq.heappop(pending)
