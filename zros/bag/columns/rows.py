"""The fast path of bag columns: a plan run over messages grouped into rows of bytes.

Messages of one connection are grouped by byte length into rows that stay in their buffers
(:class:`~zros.bag.read.payloads.Rows`), so a field at the same offset in every row is gathered in
one numpy copy and viewed with its dtype. Strings and sequences move the offset by their length:
rows are split into parts by the offset they reach, and each part goes on alone. What the plan
cannot read raises :class:`Unplannable`, and the caller decodes those messages one by one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from zros.bag.columns.plan import Leaf, Plan, Step
from zros.bag.read.payloads import Payloads, Rows, gather
from zros.cdr.arrays import Array, DType

#: beyond this many distinct layouts in a batch, decoding one by one is faster
MAX_PARTS = 64


class Unplannable(Exception):
    """The fast path cannot read these messages; decode them one by one."""


@dataclass
class Part:
    """Rows of one length group that reached the same offset."""

    rows: Rows  #: a row per message
    where: Array  #: positions of the rows in the batch
    offset: int  #: current offset relative to the CDR body


class Later:
    """The values of a sequence field in rows of one buffer, copied out when the column is
    assembled: each copy is gone before the next is made, so a long column's copies reuse one
    another's memory instead of all being alive at once (fresh memory is slow to fault in)."""

    def __init__(self, rows: Rows, start: int, stop: int, wire: DType) -> None:
        self._rows, self._start, self._stop, self._wire = rows, start, stop, wire
        self.shape = (len(rows), (stop - start) // wire.itemsize)

    def __array__(self, dtype: DType | None = None, copy: bool | None = None) -> Array:
        values = self._rows.take(self._start, self._stop).view(self._wire)
        return values if dtype is None else values.astype(dtype)


Values = Array | Later
Pieces = dict[str, list[tuple[Array, Values]]]  # leaf path -> (positions, values)


def _run(plan_: Plan, leaves: list[Leaf], parts: list[Part], pieces: Pieces) -> None:
    wanted = {leaf.path for leaf in leaves}
    todo = set(wanted)
    for step in plan_.steps:
        if not todo and not plan_.complete:
            return  # nothing left to read, and the rest cannot be checked
        if step.kind == 'stop':
            if todo:
                raise Unplannable(step.where)
            return
        if len(parts) > MAX_PARTS:
            raise Unplannable('too many layouts')
        following: list[Part] = []
        for part in parts:
            following += _step(step, part, wanted, pieces)
        parts = following
        todo -= {leaf.path for _, leaf in step.leaves if leaf is not None}
    for part in parts:
        left = part.rows.length - 4 - part.offset
        if not 0 <= left <= 3:
            raise Unplannable(f'{left} bytes left after the message')


def _step(step: Step, part: Part, wanted: set[str], pieces: Pieces) -> list[Part]:
    rows, offset = part.rows, part.offset
    body = rows.length - 4
    offset += -offset % step.align
    if step.kind == 'block':
        if offset + step.size > body:
            raise Unplannable('short message')
        spans = [
            (at, at + leaf.wire.itemsize * max(leaf.length, 1), leaf)
            for at, leaf in step.leaves
            if leaf.path in wanted
        ]
        if spans:  # one copy of the bytes from the first wanted field to the end of the last
            first = min(begin for begin, _, _ in spans)
            taken = rows.take(4 + offset + first, 4 + offset + max(end for _, end, _ in spans))
            for begin, end, leaf in spans:
                values = taken[:, begin - first : end - first].view(leaf.wire)
                pieces[leaf.path].append((part.where, values if leaf.length else values[:, 0]))
        part.offset = offset + step.size
        return [part]
    if offset + 4 > body:
        raise Unplannable('short message')
    counts = rows.take(4 + offset, 8 + offset).view('<u4')[:, 0]
    offset += 4
    if step.kind == 'string':
        return _split(part, counts, lambda count: offset + int(count) * step.size)
    # sequences of primitives or structs: the first element aligns, an empty one does not
    parts = []
    for count in np.unique(counts).tolist():
        first = offset + (-offset % step.align if count else 0)
        end = first + count * step.size
        if end > body:
            raise Unplannable('short message')
        chosen = _subset(part, counts, count)
        leaves = [leaf for _, leaf in step.leaves if leaf.path in wanted]
        at = 0
        for rows in chosen.rows.segments() if leaves else ():
            where = chosen.where[at : at + len(rows)]
            at += len(rows)
            for leaf in leaves:
                pieces[leaf.path].append((where, Later(rows, 4 + first, 4 + end, leaf.wire)))
        chosen.offset = end
        parts.append(chosen)
    return parts


def _subset(part: Part, counts: Array, count: int) -> Part:
    if len(counts) and counts[0] == count and (counts == count).all():
        return Part(part.rows, part.where, part.offset)
    mask = counts == count
    return Part(part.rows.subset(mask), part.where[mask], part.offset)


def _split(part: Part, counts: Array, offset_of: Callable[[int], int]) -> list[Part]:
    parts = []
    for count in np.unique(counts).tolist():
        chosen = _subset(part, counts, count)
        chosen.offset = offset_of(count)
        if chosen.offset > chosen.rows.length - 4:
            raise Unplannable('short message')
        parts.append(chosen)
    return parts


def _groups(batch: list[Payloads]) -> list[Part]:
    """Messages grouped by length, each group one :class:`Rows`."""
    lengths = np.concatenate([payloads.lengths() for payloads in batch])
    parts = []
    for length in np.unique(lengths).tolist():
        if length < 4:
            raise Unplannable('shorter than a CDR header')
        rows, chosen = gather(batch, length)
        head = rows.take(0, 2)
        if head[:, 0].any() or (head[:, 1] != 1).any():
            raise Unplannable('not little-endian CDR')
        parts.append(Part(rows, chosen, 0))
    return parts


def read_rows(plan_: Plan, leaves: list[Leaf], batch: list[Payloads]) -> Pieces:
    """The values of ``leaves`` in a batch of one connection's messages, by running its plan;
    raises :class:`Unplannable` where the plan cannot read them."""
    pieces: Pieces = {leaf.path: [] for leaf in leaves}
    _run(plan_, leaves, _groups(batch), pieces)
    return pieces


def payloads_of(data: Sequence[bytes]) -> Payloads:
    """A block's messages as :class:`Payloads` (as they are, or joined into one buffer)."""
    return data if isinstance(data, Payloads) else Payloads.joined(data)
