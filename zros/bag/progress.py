"""Terminal helpers of ``zros bag record`` and ``play``: a status line rewritten in place, and
single key presses. Both stay silent unless their stream is a terminal."""

from __future__ import annotations

import contextlib
import os
import select
import sys
import time
from types import TracebackType
from typing import IO


class Progress:
    """One status line on ``stream`` (stderr), rewritten at most every ``interval`` seconds;
    does nothing when the stream is not a terminal (or ``enabled`` is False)."""

    def __init__(
        self, stream: IO[str] | None = None, enabled: bool | None = None, interval: float = 0.1
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            enabled = _isatty(self.stream)
        self.enabled = enabled
        self.interval = interval
        self._last = 0.0
        self._shown = False

    def update(self, text: str, force: bool = False) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if not force and now - self._last < self.interval:
            return
        self._last = now
        self.stream.write('\r' + text + '\x1b[K')
        self.stream.flush()
        self._shown = True

    def close(self) -> None:
        """End the line (so what follows starts on a fresh one)."""
        if self._shown:
            self.stream.write('\n')
            self.stream.flush()
            self._shown = False


def _isatty(stream: IO[str]) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


#: escape sequences of the keys the player reacts to
_ARROWS = {'\x1b[A': 'up', '\x1b[B': 'down', '\x1b[C': 'right', '\x1b[D': 'left'}


class Keys:
    """Single key presses from stdin while it is a terminal (cbreak mode, no echo).

    ``read(timeout)`` returns ``' '``, ``'q'``, ``'up'``, ``'right'``... or None. Elsewhere
    (a pipe, a test, Windows) it is disabled and returns None at once.
    """

    def __init__(self, stream: IO[str] | None = None) -> None:
        self.stream = stream if stream is not None else sys.stdin
        self.enabled = _isatty(self.stream) and os.name == 'posix'
        self._saved: list[int | list[bytes | int]] | None = None  #: termios attributes

    def __enter__(self) -> Keys:
        if self.enabled:
            import termios  # noqa: PLC0415 (POSIX only)
            import tty  # noqa: PLC0415 (POSIX only)

            fd = self.stream.fileno()
            self._saved = termios.tcgetattr(fd)
            tty.setcbreak(fd)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if self._saved is not None:
            import termios  # noqa: PLC0415 (POSIX only)

            with contextlib.suppress(Exception):
                termios.tcsetattr(self.stream.fileno(), termios.TCSADRAIN, self._saved)
            self._saved = None

    def read(self, timeout: float) -> str | None:
        """The next key pressed within ``timeout`` seconds, or None."""
        if not self.enabled:
            return None
        fd = self.stream.fileno()
        ready, _, _ = select.select([fd], [], [], timeout)
        if not ready:
            return None
        key = os.read(fd, 1).decode(errors='replace')
        if key == '\x1b':  # an arrow: ESC [ X
            more, _, _ = select.select([fd], [], [], 0.01)
            if more:
                key += os.read(fd, 2).decode(errors='replace')
            return _ARROWS.get(key, 'escape')
        return key
