"""A reusable output buffer for encoding large messages."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from zros.cdr.arrays import Array

#: one piece of an encoded message: bytes-like, or a numpy array whose data is written as is
Part = bytes | bytearray | memoryview | Array
#: assembles the parts of an encoded message (``b''.join``, or ``EncodeBuffer.join``)
Join = Callable[[Sequence[Part]], bytes | bytearray]


class EncodeBuffer:
    """Assembles encoded parts into one bytearray reused from message to message.

    A fresh multi-megabyte object per message costs page faults and zeroing in the kernel, which
    halves the rate of a camera publisher. Messages under ``threshold`` bytes are joined into new
    ``bytes`` (faster for them). The result is valid until the next call: use it, then encode again.
    """

    __slots__ = ('_buffer', 'threshold')

    def __init__(self, threshold: int = 65536) -> None:
        self._buffer = bytearray()
        self.threshold = threshold

    def join(self, parts: Sequence[Part]) -> bytes | bytearray:
        """The parts (bytes-like objects and numpy arrays) one after another."""
        sizes = [part.nbytes if type(part) is np.ndarray else len(part) for part in parts]
        total = sum(sizes)
        if total < self.threshold:
            return b''.join(parts)  # type: ignore[arg-type]  # arrays are buffers: stubs omit it
        buffer = self._buffer
        if len(buffer) < total:
            buffer = self._buffer = bytearray(total)
        elif len(buffer) > total:
            del buffer[total:]
        view = memoryview(buffer)
        try:
            offset = 0
            for part, size in zip(parts, sizes, strict=True):
                source = part.view(np.uint8) if type(part) is np.ndarray else part
                view[offset : offset + size] = source  # type: ignore[assignment]  # as above
                offset += size
        finally:
            view.release()
        return buffer
