"""How many clients a gateway serves at once: every connection costs a thread or two and its
buffers, so a program (or, off loopback, a peer) that opens thousands must not take the
machine. Past the bound a connection gets HTTP 503 and the log says so, at most once in
:data:`NOTICE_PERIOD` seconds."""

from __future__ import annotations

import logging
import threading
import weakref

from zros.gateway.common.drop_notice import DropNotices
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.limits import MAX_CLIENTS

_log = logging.getLogger('zros.gateway')

#: seconds between two log lines about refused connections
NOTICE_PERIOD = 10.0


def check_max_clients(limit: int) -> int:
    """``limit`` if a gateway can serve that many clients at once; else GatewayError."""
    if limit < 1:
        raise GatewayError(f'a gateway must take at least 1 client at once, not {limit}')
    return limit


class Admission:
    """The connections a gateway serves now, at most ``limit``: :meth:`enter` admits one (or
    says no), :meth:`leave` lets it go. A connection is held weakly: one that is gone without
    leaving (its handshake failed) frees its place when it is collected. Thread-safe."""

    def __init__(self, limit: int = MAX_CLIENTS, option: str = '--max-clients') -> None:
        self.limit = check_max_clients(limit)
        self.refused = 0  #: connections refused so far
        self._option = option
        self._held: weakref.WeakSet[object] = weakref.WeakSet()
        self._lock = threading.Lock()
        self._notices = DropNotices(NOTICE_PERIOD)

    def __len__(self) -> int:
        with self._lock:
            return len(self._held)

    def enter(self, connection: object) -> bool:
        """Admit ``connection`` if there is room; else count and log the refusal."""
        with self._lock:
            if len(self._held) < self.limit:
                self._held.add(connection)
                return True
            self.refused += 1
            refused = self.refused
        new = self._notices.due(refused)
        if new is not None:
            _log.warning(
                'refused %d connection%s: the server serves at most %d client%s at once '
                '(%s raises it)',
                new,
                '' if new == 1 else 's',
                self.limit,
                '' if self.limit == 1 else 's',
                self._option,
            )
        return False

    def leave(self, connection: object) -> None:
        """``connection`` ended (nothing happens if it was never admitted)."""
        with self._lock:
            self._held.discard(connection)

    def refusal(self) -> str:
        """What a refused connection is told."""
        plural = '' if self.limit == 1 else 's'
        return (
            f'too many clients: this server serves at most {self.limit} client{plural} at once '
            f'({self._option} raises it)'
        )
