"""Payloads of many messages as offsets into one buffer, without a bytes object per message.

A decompressed MCAP chunk holds the payloads of its messages between record headers;
:class:`Payloads` keeps the chunk and the (begin, end) offsets of one channel's payloads. A
message is sliced out only when asked for. :func:`gather` makes the messages of one length
:class:`Rows` that stay in their buffers: ``Bag.columns`` copies out only the bytes of the fields
it reads, where slicing each payload and joining them copied every byte twice, made a Python
object per message and, on a machine where fresh memory is slow to fault in, spent most of
its time there.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, overload

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    #: which payloads or rows to keep: a boolean mask, or indices
    Keep = npt.NDArray[np.bool_] | npt.NDArray[np.int64]


class Payloads(Sequence[bytes]):
    """Messages ``buffer[begins[i]:ends[i]]``; ``begins`` and ``ends`` are int64 arrays."""

    buffer: bytes | memoryview  #: the buffer the payloads lie in (a file's map, say)

    def __init__(
        self, buffer: bytes | memoryview, begins: npt.NDArray[np.int64], ends: npt.NDArray[np.int64]
    ) -> None:
        if len(begins) != len(ends):
            raise ValueError('as many begins as ends are needed')
        if len(begins) and (begins.min() < 0 or ends.max() > len(buffer) or (ends < begins).any()):
            raise ValueError('a payload beyond its buffer')
        self.buffer = buffer
        self.begins = begins
        self.ends = ends

    @classmethod
    def joined(cls, datas: Iterable[bytes]) -> Payloads:
        """Payloads of separate bytes objects, joined into one buffer."""
        datas = list(datas)
        lengths = np.fromiter(map(len, datas), np.int64, len(datas))
        ends = np.cumsum(lengths)
        return cls(b''.join(datas), ends - lengths, ends)

    def __len__(self) -> int:
        return len(self.begins)

    @overload
    def __getitem__(self, index: int) -> bytes: ...

    @overload
    def __getitem__(self, index: slice[object, object, object]) -> Payloads: ...

    def __getitem__(self, index: int | slice[object, object, object]) -> bytes | Payloads:
        if isinstance(index, slice):
            return Payloads(self.buffer, self.begins[index], self.ends[index])
        return bytes(self.buffer[int(self.begins[index]) : int(self.ends[index])])

    def __iter__(self) -> Iterator[bytes]:
        buffer, spans = self.buffer, zip(self.begins.tolist(), self.ends.tolist(), strict=True)
        if isinstance(buffer, bytes):  # slices of bytes are bytes already
            return iter([buffer[b:e] for b, e in spans])
        return iter([bytes(buffer[b:e]) for b, e in spans])

    def __repr__(self) -> str:
        return f'<Payloads of {len(self)} messages>'

    def lengths(self) -> npt.NDArray[np.int64]:
        """The length of each payload (int64)."""
        lengths: npt.NDArray[np.int64] = self.ends - self.begins
        return lengths

    def select(self, keep: Keep) -> Payloads:
        """The payloads where ``keep`` (a boolean mask or indices) says."""
        return Payloads(self.buffer, self.begins[keep], self.ends[keep])


class Rows:
    """Messages of one length, a row each, left where they lie in their buffers (``segments``:
    a uint8 buffer and the int64 starts of its rows). :meth:`take` copies out a range of
    columns of every row, so only the bytes of the fields read are ever copied."""

    def __init__(
        self, segments: list[tuple[npt.NDArray[np.uint8], npt.NDArray[np.int64]]], length: int
    ) -> None:
        self._segments = [(raw, begins) for raw, begins in segments if len(begins)]
        self.length = length

    def __len__(self) -> int:
        return sum(len(begins) for _, begins in self._segments)

    def take(self, start: int, stop: int) -> npt.NDArray[np.uint8]:
        """Bytes ``start:stop`` of every row, as a C-contiguous (rows, stop - start) array."""
        if not 0 <= start <= stop <= self.length:
            raise ValueError(f'columns {start}:{stop} of rows of {self.length} bytes')
        width = stop - start
        if width == 0 or not self._segments:
            return np.empty((len(self), width), np.uint8)
        parts = []
        for raw, begins in self._segments:
            # every window of ``width`` bytes of the buffer, as a view: row i starts at byte i
            windows = np.ndarray((len(raw) - width + 1, width), np.uint8, raw, 0, (1, 1))
            parts.append(windows[begins + start])
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    def segments(self) -> list[Rows]:
        """The rows of each buffer, in order."""
        return [Rows([segment], self.length) for segment in self._segments]

    def subset(self, keep: npt.NDArray[np.bool_]) -> Rows:
        """The rows where the boolean mask ``keep`` is true."""
        segments, at = [], 0
        for raw, begins in self._segments:
            segments.append((raw, begins[keep[at : at + len(begins)]]))
            at += len(begins)
        return Rows(segments, self.length)


def gather(batch: Sequence[Payloads], length: int) -> tuple[Rows, npt.NDArray[np.int64]]:
    """The messages of ``length`` bytes of a batch, as :class:`Rows`, and their positions in
    the batch (int64, counted across its payloads in order)."""
    segments, where = [], []
    base = 0
    for payloads in batch:
        which = np.flatnonzero(payloads.lengths() == length)
        if len(which):
            segments.append((np.frombuffer(payloads.buffer, np.uint8), payloads.begins[which]))
            where.append(which + base)
        base += len(payloads)
    positions = np.concatenate(where) if where else np.empty(0, np.int64)
    return Rows(segments, length), positions
