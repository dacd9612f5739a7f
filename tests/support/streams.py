"""A child's pipe read as it comes: a pipe nobody reads fills (64 KiB) and then blocks the child
on its next write, so a chatty process would never end."""

from __future__ import annotations

import threading
from typing import IO


class Drained:
    """Everything written to ``stream``, read by a thread of its own until the writer closes it."""

    def __init__(self, stream: IO[str] | None) -> None:
        self._parts: list[str] = []
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream: IO[str] | None) -> None:
        if stream is None:
            return
        for line in stream:
            self._parts.append(line)

    def text(self, timeout: float = 10.0) -> str:
        """What was written: all of it once the writer ended (waits up to ``timeout`` s)."""
        self._thread.join(timeout)
        return ''.join(self._parts)
