"""One column of a topic: pieces of rows written into one array allocated for the topic."""

from __future__ import annotations

import numpy as np

from zros.bag.columns.plan import Leaf
from zros.bag.columns.rows import Values
from zros.cdr.arrays import Array, DType


def assemble(
    leaf: Leaf, pieces: list[tuple[Array, Values]], size: int, out: Column | None = None
) -> Array | None:
    """One column of a block from pieces of rows: written into ``out`` where its rows have
    the shape of the column's (then None), else returned."""
    shapes = {values.shape[1:] for _, values in pieces}
    if len(shapes) <= 1:
        shape = shapes.pop() if shapes else ((0,) if leaf.sequence else ())
        if leaf.length:
            shape = (leaf.length,)
        target = None if out is None else out.rows(size, shape, leaf.value)
        written = target is not None
        if target is None:
            target = np.empty((size, *shape), leaf.value)
        for where, values in pieces:
            target[where] = values
        return None if written else target
    ragged = np.empty(size, object)
    for where, values in pieces:
        converted = np.asarray(values).astype(leaf.value)
        for row, index in enumerate(where.tolist()):
            ragged[index] = converted[row]
    return ragged


class Column:
    """One column of a topic, filled batch by batch into one array allocated for the whole
    topic: its rows are never held twice (per-batch arrays joined at the end were)."""

    def __init__(self, leaf: Leaf, capacity: int) -> None:
        self.leaf = leaf
        self.capacity = capacity
        self.array: Array | None = None
        self.size = 0

    def rows(self, count: int, shape: tuple[int, ...], dtype: DType) -> Array | None:
        """The next ``count`` rows to write into (a view), if they have ``shape``."""
        array = self.array
        if array is None:
            array = self.array = np.empty((max(self.capacity, count), *shape), dtype)
        elif array.dtype == object or array.shape[1:] != shape:
            return None
        elif self.size + count > len(array):  # more messages than counted: grow
            grown = np.empty((max(len(array) * 3 // 2, self.size + count), *shape), dtype)
            grown[: self.size] = array[: self.size]
            array = self.array = grown
        self.size += count
        return array[self.size - count : self.size]

    def add(self, pieces: list[tuple[Array, Values]], count: int) -> None:
        """The rows of a batch (``pieces`` as :func:`assemble` takes them)."""
        if not count:
            return
        other = assemble(self.leaf, pieces, count, self)
        if other is None:
            return
        # rows of another shape (sequences whose length changed): a column of 1-D arrays
        array = self.array
        if array is None or array.dtype != object:
            ragged = np.empty(max(self.capacity, self.size + count), object)
            if array is not None:
                for index in range(self.size):
                    ragged[index] = array[index]
            array = self.array = ragged
        elif self.size + count > len(array):
            grown = np.empty(max(len(array) * 3 // 2, self.size + count), object)
            grown[: self.size] = array[: self.size]
            array = self.array = grown
        for row in range(count):
            array[self.size + row] = other[row]
        self.size += count

    def result(self, order: Array | None) -> Array:
        """The column in time order (``order``: the rows' order where arrival is not)."""
        if self.array is None:
            empty = assemble(self.leaf, [], 0)
            assert empty is not None  # nothing to write into
            return empty
        column = self.array[: self.size]
        if order is not None:
            # only the rows out of place move: a copy of those, not of the column
            moved = np.flatnonzero(order != np.arange(len(order)))
            first, last = int(moved[0]), int(moved[-1]) + 1
            column[first:last] = column[order[first:last]]
        return column
