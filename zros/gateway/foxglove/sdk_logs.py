"""The Foxglove SDK's own log, bounded: the SDK logs once per bad request of a client (a
``subscribe`` op naming 300,000 unknown channels wrote 300,000 lines), so a client could fill
a disk through it.

The SDK's records reach Python's ``logging`` under ``foxglove.*`` names, formatted already
(each names its client and channel, so no two are alike). :func:`bound_sdk_logs` takes them off
that tree and hands them on under ``zros.gateway.sdk``, at most :data:`BURST` per logger and
level in each :data:`PERIOD`; the first one let through after a pause says how many were left
out.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

#: records of one SDK logger and level let through in each period
BURST = 5
#: seconds of one period
PERIOD = 10.0
#: the logger the SDK's records go on to (its handlers, and zros's and the root's above it)
FORWARD_TO = 'zros.gateway.sdk'


class LogLimit(logging.Filter):
    """Lets through at most ``burst`` records per logger name and level in each ``period``
    seconds; the next one let through tells how many were left out. Thread-safe."""

    def __init__(
        self,
        burst: int = BURST,
        period: float = PERIOD,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        super().__init__()
        self.burst = burst
        self.period = period
        self._clock = clock
        self._lock = threading.Lock()
        #: per (logger, level): the period's start, records let through in it, records left out
        self._state: dict[tuple[str, int], tuple[float, int, int]] = {}

    def filter(self, record: logging.LogRecord) -> bool:
        key = (record.name, record.levelno)
        now = self._clock()
        with self._lock:
            start, passed, left_out = self._state.get(key, (now, 0, 0))
            if now - start >= self.period:
                start, passed = now, 0
            if passed >= self.burst:
                self._state[key] = (start, passed, left_out + 1)
                return False
            self._state[key] = (start, passed + 1, 0)
        if left_out:
            record.msg = f'{record.getMessage()} ({left_out} more like it left out)'
            record.args = ()
        return True


class _Forward(logging.Handler):
    """Hands each record the filter lets through to :data:`FORWARD_TO`."""

    def emit(self, record: logging.LogRecord) -> None:
        logging.getLogger(FORWARD_TO).handle(record)


_installed = threading.Lock()


def bound_sdk_logs(limit: LogLimit | None = None) -> None:
    """Route the SDK's log (``foxglove.*``) through a :class:`LogLimit`; once per process."""
    sdk = logging.getLogger('foxglove')
    with _installed:
        if any(isinstance(handler, _Forward) for handler in sdk.handlers):
            return
        forward = _Forward()
        forward.addFilter(limit or LogLimit())
        sdk.addHandler(forward)
        sdk.propagate = False
