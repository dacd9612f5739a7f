"""When a gateway tells a slow client (and its log) that the client's oldest messages were
dropped: at most once a second, counting the drops since the last notice."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

#: seconds between two notices of one client's dropped messages
NOTICE_PERIOD = 1.0


class DropNotices:
    """The drop notices of one client: :meth:`due` says whether one may go now (at most one
    per ``period`` seconds) and what it tells. Thread-safe."""

    def __init__(
        self, period: float = NOTICE_PERIOD, clock: Callable[[], float] = time.monotonic
    ) -> None:
        self.period = period
        self._clock = clock
        self._lock = threading.Lock()
        self._next = -math.inf  #: when a notice may go again
        self.told = 0  #: the drops told so far

    def due(self, dropped: int) -> int | None:
        """The drops since the last notice when a notice is due now (it then counts as
        sent), else None; ``dropped`` counts the client's drops so far."""
        now = self._clock()
        with self._lock:
            if now < self._next or dropped <= self.told:
                return None
            self._next = now + self.period
            new, self.told = dropped - self.told, dropped
            return new
