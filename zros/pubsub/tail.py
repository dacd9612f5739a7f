"""The newest large message of a stream, for a subscriber whose slow link dropped it.

A reliable keep-last publisher drops messages rather than wait for a slow link, and a router on
the way sends large ones on with ``block_first`` (``zros router``): while one image crosses a
slow link, those written meanwhile are dropped. When the stream stops, the last image to arrive
is the one that was on its way, up to a link-time's worth of images older than the last written.
DDS repairs to the newest there. zros does the same between zros nodes, once a stream pauses:

* A publisher whose messages can be large (:func:`can_be_large`) keeps the newest of
  :data:`LARGE` bytes or more, with the Zenoh timestamp it put it with, and answers queries on
  ``@zros/newest/<its key>`` (declared with its first large message) (:class:`Newest`).
* A reliable subscriber that received large messages and then none for a while (twice the usual
  gap between them, within :data:`QUIET`) asks once, sending a token of its own and the
  timestamps of the last large messages it received (:class:`Tail`).
* A publisher whose newest is not among those puts it on ``@zros/tail/<token>``, which only that
  subscriber listens to: a plain message of the publisher's own priority sent ``block_first``,
  which routers send on as they send the stream's large messages (small messages overtaking
  it), never a query reply (a reply holds the messages behind it). The subscriber takes it as
  the next message unless one arrived since it asked.

Nothing is sent again to a subscriber that has the newest; other subscribers never see it; and
publishers other than zros's (no answer) or subscribers other than zros's (no question) are
unaffected.
"""

from __future__ import annotations

import collections
import logging
import re
import secrets
import threading
import time
import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING

from zenoh import CongestionControl, ZError

from zros.cdr import definition_of
from zros.cdr.model import Kind
from zros.runtime.entity import Undeclarable
from zros.transport.per_session import PerSession
from zros.transport.router import LARGE_PAYLOAD
from zros.transport.session import Transport

if TYPE_CHECKING:
    from zenoh import Priority, Query, Sample, Session, Timestamp

    from zros.cdr.message import Message

_log = logging.getLogger('zros')

#: the size from which a message is kept, and asked for: the size from which routers send it on
#: with ``block_first`` (smaller ones are dropped only when a link's queue is full)
LARGE = LARGE_PAYLOAD
#: where publishers answer, and where the newest goes to one subscriber
NEWEST = '@zros/newest/'
TAIL = '@zros/tail/'
#: seconds without a large message before a subscriber asks: twice the usual gap, within these
QUIET = (0.5, 5.0)
#: the timestamps a question carries: the last large messages received
HAVES = 16
#: the most newest messages a publisher sends in one second (a question costs a peer nothing)
MAX_SENT = 10
_TOKEN = re.compile(r'[0-9a-f]{32}')


def can_be_large(cls: type[Message]) -> bool:
    """Whether messages of ``cls`` can reach :data:`LARGE` bytes: it has arrays, sequences or
    nested messages (else its size is a few strings at most)."""
    return any(
        f.type.kind is not Kind.SCALAR or f.type.is_nested for f in definition_of(cls).fields
    )


# --- the publisher's side ------------------------------------------------------------------


class Newest:
    """A publisher's newest large message, for the subscribers that ask.

    ``stamp(data)`` is called with every payload before it is put: for a large one it keeps
    ``data`` (not copied: the publisher writes the next large message elsewhere) and returns the
    timestamp to put it with; for a small one it returns None.
    """

    def __init__(self, session: Session, key: str, priority: Priority) -> None:
        self._session = session
        self._key = NEWEST + key
        self._priority = priority
        self._lock = threading.Lock()
        self._data: bytes | bytearray | None = None
        self._stamp: Timestamp | None = None
        self._queryable: Undeclarable | None = None
        self._closed = False
        self._sent: collections.deque[float] = collections.deque()  #: when, this last second
        self.sent = 0  #: newest messages sent to subscribers that asked
        self.ignored = 0  #: queries that were not questions
        self.refused = 0  #: questions past :data:`MAX_SENT` a second

    def stamp(self, data: bytes | bytearray) -> Timestamp | None:
        """The timestamp to put ``data`` with, after keeping it if it is large."""
        if len(data) < LARGE:
            return None
        stamp = self._session.new_timestamp()
        with self._lock:  # a copy for a subscriber is made under it: the old data is free after
            self._data, self._stamp = data, stamp
            if self._queryable is None and not self._closed:
                self._queryable = self._session.declare_queryable(self._key, self._on_query)
        return stamp

    def _on_query(self, query: Query) -> None:
        payload = query.payload
        try:
            token, haves = parse_question(b'' if payload is None else payload.to_bytes())
        except ValueError as exc:
            _log.debug('ignored a question for the newest on %s: %s', self._key, exc)
            self.ignored += 1
            return
        with self._lock:
            if self._data is None or self._stamp is None or str(self._stamp) in haves:
                return
            now = time.monotonic()
            while self._sent and now - self._sent[0] >= 1.0:
                self._sent.popleft()
            if len(self._sent) >= MAX_SENT:
                self.refused += 1
                return
            self._sent.append(now)
            data, stamp = bytes(self._data), self._stamp
        # block_first: one answer waits for room rather than being dropped (a busy local link
        # dropped a fragmented one under drop), and never the writer, which puts with drop; off
        # Zenoh's thread, which takes all the session's incoming messages
        threading.Thread(
            target=self._send, args=(TAIL + token, data, stamp), name='zros newest', daemon=True
        ).start()

    def _send(self, key: str, data: bytes, stamp: Timestamp) -> None:
        try:
            self._session.put(
                key, data, congestion_control=CongestionControl.BLOCK_FIRST,
                priority=self._priority, timestamp=stamp,
            )  # fmt: skip
        except ZError:  # the session closes
            return
        self.sent += 1

    def close(self) -> None:
        """Stop answering and let the newest go."""
        with self._lock:
            self._closed = True
            queryable, self._queryable = self._queryable, None
            self._data = self._stamp = None
        if queryable is not None:
            try:
                queryable.undeclare()
            except ZError:  # the session closes
                _log.debug('undeclaring a queryable of %s failed', self._key, exc_info=True)


def ask(token: str, haves: collections.deque[str] | list[str]) -> bytes:
    """A question's payload: the asker's token, then the timestamps it has, a line each."""
    return '\n'.join([token, *haves]).encode()


def parse_question(payload: bytes) -> tuple[str, set[str]]:
    """The token and the timestamps of a question; ValueError when it is not one."""
    try:
        lines = payload.decode('ascii').split('\n')
    except UnicodeDecodeError:
        raise ValueError('not ASCII') from None
    token = lines[0]
    if not _TOKEN.fullmatch(token):
        raise ValueError(f'{token[:40]!r} is not a token')
    if len(lines) > HAVES + 1 or any(len(line) > 64 for line in lines):
        raise ValueError('too long')
    return token, set(lines[1:])


# --- the subscriber's side -----------------------------------------------------------------


class Tail:
    """What one subscriber knows of the large messages it received, to ask for the newest
    once they stop coming; ``deliver(samples)`` takes the newest when it comes."""

    def __init__(
        self, transport: Transport, key: str, deliver: Callable[[list[Sample]], None]
    ) -> None:
        self._transport = transport
        self._key = NEWEST + key
        self._deliver = deliver
        self.token = secrets.token_hex(16)
        self._lock = threading.Lock()
        self._haves: collections.deque[str] = collections.deque(maxlen=HAVES)
        self._last = 0.0  #: when the last large message came (monotonic)
        self._gap = 0.0  #: the usual gap between them (a moving average)
        self._asked_at = 0.0
        self._waiting = False  #: a large message came since it last asked
        self._subscriber: Undeclarable | None = None
        self._closed = False
        self.asked = 0  #: questions sent
        self.recovered = 0  #: newest messages taken

    def seen(self, samples: list[Sample]) -> None:
        """Note the large ones among ``samples`` (live messages)."""
        for sample in samples:
            if len(sample.payload) >= LARGE:
                self._note(sample)

    def _note(self, sample: Sample) -> None:
        now = time.monotonic()
        stamp = sample.timestamp
        with self._lock:
            if self._closed:
                return
            if self._last:
                gap = now - self._last
                self._gap = gap if not self._gap else 0.75 * self._gap + 0.25 * gap
            self._last = now
            if stamp is not None:
                self._haves.append(str(stamp))
            self._waiting = True
            first = self._subscriber is None
            if first:
                session = self._transport.session
                self._subscriber = session.declare_subscriber(TAIL + self.token, self._on_tail)
        if first:
            tail_watch_of(self._transport).add(self)

    def due(self) -> float | None:
        """When it should ask (monotonic time), or None while it has nothing to ask."""
        with self._lock:
            if not self._waiting or self._closed:
                return None
            quiet = min(QUIET[1], max(QUIET[0], 2 * self._gap))
            return self._last + quiet

    def ask(self) -> None:
        """Ask the publishers for their newest (once: again after the next large message)."""
        with self._lock:
            if not self._waiting or self._closed:
                return
            self._waiting = False
            self._asked_at = time.monotonic()
            payload = ask(self.token, self._haves)
        try:
            self._transport.session.get(self._key, _ignore, payload=payload, timeout=10.0)
        except ZError:  # the session closes
            return
        self.asked += 1

    def _on_tail(self, sample: Sample) -> None:
        stamp = sample.timestamp
        with self._lock:
            if self._closed or self._last > self._asked_at or stamp is None:
                return  # a newer one came meanwhile
            if str(stamp) in self._haves:
                return
            self._haves.append(str(stamp))
            self.recovered += 1
        self._deliver([sample])

    def close(self) -> None:
        """Stop asking and listening."""
        with self._lock:
            self._closed = True
            subscriber, self._subscriber = self._subscriber, None
        if subscriber is not None:
            watch = tail_watch_of.peek(self._transport)
            if watch is not None:
                watch.remove(self)
            try:
                subscriber.undeclare()
            except ZError:  # the session closes
                _log.debug('undeclaring a subscriber of %s failed', self._key, exc_info=True)


def _ignore(_reply: object) -> None:
    """Publishers answer by putting the newest, not by replying."""


class TailWatch:
    """The session's subscribers that received large messages: a thread asks for each one's
    newest when its stream has paused."""

    PERIOD = 0.1  #: seconds between two looks while some subscriber waits

    def __init__(self, transport: Transport) -> None:
        self._transport = transport
        self._tails: weakref.WeakSet[Tail] = weakref.WeakSet()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    def add(self, tail: Tail) -> None:
        """Watch ``tail`` until it closes or is gone."""
        with self._lock:
            self._tails.add(tail)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name='zros tails', daemon=True)
                self._thread.start()

    def remove(self, tail: Tail) -> None:
        """Stop watching ``tail`` (it closed); the thread ends with the last one."""
        with self._lock:
            self._tails.discard(tail)

    def _run(self) -> None:
        transport = self._transport
        while not transport.closed:
            time.sleep(self.PERIOD)
            now = time.monotonic()
            with self._lock:
                tails = list(self._tails)
                if not tails:
                    self._thread = None
                    return
            for tail in tails:
                due = tail.due()
                if due is not None and due <= now:
                    tail.ask()
        with self._lock:
            self._thread = None


#: the watch of a session, made with its first subscriber that receives a large message
tail_watch_of = PerSession(TailWatch)
