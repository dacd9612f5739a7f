"""What a subscription drops, counted per sender and logged without flooding the log.

A subscription drops a sample that does not decode as its type, one without a valid rmw_zenoh
attachment (on that wire), and, past the memory bound of a keep-all queue, every new sample.
Each drop is counted under who sent it, named as precisely as the wire allows
(:func:`sender_key`, and ``zros.pubsub.senders``). The first drop of a kind from a sender is logged
at once; later ones are summed up in one line per :data:`SUMMARY_INTERVAL` seconds, and what
is left unreported when the subscription closes is logged then. A flood of garbage therefore
costs a few log lines, and a second attacker is reported as well as the first.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from zros.wire import read_attachment

if TYPE_CHECKING:
    from zenoh import Sample

_log = logging.getLogger('zros')

#: seconds between two log lines about the drops from one sender
SUMMARY_INTERVAL = 10.0
#: senders told apart per subscription; beyond, drops are counted together
MAX_SENDERS = 256
OTHERS = 'other senders (too many to tell apart)'


def sender_key(sample: Sample) -> str:
    """Who sent ``sample``, as precisely as it tells: the GID of its rmw_zenoh attachment, its
    Zenoh source info, else the id in its timestamp (the sending session's, or that of the
    first router on its way when the sender does not timestamp)."""
    if sample.attachment is not None:
        attachment = read_attachment(sample)
        if attachment is not None:
            return 'gid:' + attachment.gid.hex()
    info = sample.source_info
    if info is not None:
        return f'source:{info.source_id.zid}/{info.source_id.eid}'
    stamp = sample.timestamp
    if stamp is not None:
        return f'session:{stamp.get_id()}'
    return 'unknown:'


def _messages(count: int) -> str:
    return 'message' if count == 1 else 'messages'


@dataclass
class _Tally:
    label: str
    count: int = 0
    unreported: int = 0
    logged_at: float = 0.0
    reason: str | Callable[[], str] = ''


class DropCounter:
    """Drops of one subscription by sender, logged at most once per sender and interval."""

    def __init__(self, topic: str) -> None:
        self.topic = topic
        self._tallies: dict[str, _Tally] = {}
        self._lock = threading.Lock()

    def add(self, key: str, label: Callable[[], str], reason: str | Callable[[], str]) -> None:
        """Count one drop from sender ``key`` (``label()`` names it the first time); ``reason``
        may be a function, called only when a line is logged."""
        tally = self._tallies.get(key)
        if tally is None:
            if len(self._tallies) >= MAX_SENDERS:
                key, name = OTHERS, OTHERS
            else:
                name = label()
            with self._lock:
                tally = self._tallies.setdefault(key, _Tally(name))
        now = time.monotonic()
        with self._lock:
            tally.count += 1
            tally.unreported += 1
            tally.reason = reason
            first = tally.count == 1
            if not first and now - tally.logged_at < SUMMARY_INTERVAL:
                return
            count, unreported, since = tally.count, tally.unreported, tally.logged_at
            tally.unreported, tally.logged_at = 0, now
        sender = f' from {tally.label}' if tally.label else ''
        why = reason() if callable(reason) else reason
        if first:
            _log.warning(
                'dropped a message on %s%s: %s (further drops from it are summed up every %g s)',
                self.topic, sender, why, SUMMARY_INTERVAL,
            )  # fmt: skip
        else:
            _log.warning(
                'dropped %d more %s on %s%s in the last %.0f s (%d in all): %s',
                unreported, _messages(unreported), self.topic, sender, now - since, count, why,
            )  # fmt: skip

    def counts(self) -> dict[str, int]:
        """Drops so far by sender name."""
        with self._lock:
            return {tally.label: tally.count for tally in self._tallies.values()}

    def flush(self) -> None:
        """Log the drops not reported yet (the subscription closes)."""
        with self._lock:
            pending = [(t.label, t.unreported, t.count, t.reason) for t in self._tallies.values()]
            for tally in self._tallies.values():
                tally.unreported = 0
        for label, unreported, count, reason in pending:
            if unreported:
                sender = f' from {label}' if label else ''
                _log.warning(
                    'dropped %d more %s on %s%s before it closed (%d in all): %s',
                    unreported, _messages(unreported), self.topic, sender, count,
                    reason() if callable(reason) else reason,
                )  # fmt: skip
