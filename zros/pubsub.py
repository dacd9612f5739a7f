"""Publishers and subscribers on Zenoh keys of zenoh-bridge-ros2dds.

A subscriber keeps received samples as raw Zenoh payloads in a queue bounded by its QoS depth,
and decodes them only when read: samples overwritten unread cost nothing. Reads never block;
callbacks run when the node spins; ``async for`` works on the same queue.
"""

from __future__ import annotations

import asyncio
import collections
import logging
import threading
import time
from collections.abc import AsyncIterator, Callable
from typing import TYPE_CHECKING, Any

from zros.cdr import CdrError, encode
from zros.cdr.message import EncodeBuffer, Message, decode
from zros.cdr.model import Kind
from zros.keyexpr.bridge import EntityKind
from zros.qos import QoS, QoSLike, as_qos
from zros.signal import Signal
from zros.wire import Sequence, entity_wire, has_attachment

if TYPE_CHECKING:
    from zros.node import Node

_log = logging.getLogger('zros')

#: a keep-all subscriber holds at most this many unread messages, then slows its publishers
KEEP_ALL_LIMIT = 10_000
#: how many distinct bad publishers a subscriber remembers (each is reported once)
_BAD_SOURCES_LIMIT = 256


def _node(node: Node | None) -> Node:
    if node is not None:
        return node
    from zros.api import default_node

    return default_node()


def _message_class(node: Node, msg_type: str | type[Message]) -> type[Message]:
    if isinstance(msg_type, type):
        if not issubclass(msg_type, Message):
            raise TypeError(f'{msg_type!r} is not a zros message class')
        return msg_type
    return node.registry.get_class(msg_type)


class _Entity:
    """What publishers and subscribers share: a node, a topic, a Zenoh key and a token."""

    kind: EntityKind

    def __init__(
        self,
        node: Node,
        topic: str,
        msg_type: str | type[Message],
        qos: QoSLike | None,
        announce: bool = True,
    ) -> None:
        self.node = node
        self.msg_type = _message_class(node, msg_type)
        self.type_name = self.msg_type.__msgtype__
        self.topic = node.resolve_name(topic)
        self.qos: QoS = as_qos(qos)
        wire = entity_wire(
            node, self.kind, self.topic, self.type_name, self.msg_type._registry, qos=self.qos,
            announce=announce,
        )  # fmt: skip
        self.key = wire.key
        #: the liveliness tokens announcing it (through a bridge: its owner first)
        self._tokens: tuple[str, ...] = wire.tokens
        self.gid = wire.gid  #: rmw_zenoh: the GID in its attachments (and its token's hash)
        self._closed = False

    def _announce(self) -> None:
        for token in self._tokens:
            self.node.transport.declare_token(token)

    def _withdraw(self) -> None:
        for token in reversed(self._tokens):
            self.node.transport.release_token(token)

    @property
    def closed(self) -> bool:
        return self._closed


class Publisher(_Entity):
    """Publishes messages of one type on one topic (rosR: ``ros.Publisher``).

    ``qos`` is a :class:`zros.QoS`, a depth or a preset name (``'sensor_data'``). Reliable
    publishers block when the network cannot keep up; best-effort ones drop.
    """

    kind = EntityKind.PUBLISHER

    def __init__(
        self,
        topic: str,
        msg_type: str | type[Message],
        qos: QoSLike | None = None,
        *,
        node: Node | None = None,
        announce: bool = True,
    ) -> None:
        import zenoh

        owner = _node(node)
        owner._check_open()
        super().__init__(owner, topic, msg_type, qos, announce)
        session = owner.transport.session
        congestion = (
            zenoh.CongestionControl.BLOCK if self.qos.reliable else zenoh.CongestionControl.DROP
        )
        reliability = (
            zenoh.Reliability.RELIABLE if self.qos.reliable else zenoh.Reliability.BEST_EFFORT
        )
        if self.qos.transient_local:
            from zenoh import ext

            cache = ext.CacheConfig(max_samples=self.qos.depth)
            miss = None
            if self.gid is not None and self.qos.reliable:  # as rmw_zenoh publishers do
                miss = ext.MissDetectionConfig(heartbeat=None, sporadic_heartbeat=0.5)
            self._publisher: Any = ext.declare_advanced_publisher(
                session,
                self.key,
                cache=cache,
                publisher_detection=True,
                congestion_control=congestion,
                reliability=reliability,
                sample_miss_detection=miss,
            )
        else:
            self._publisher = session.declare_publisher(
                self.key, congestion_control=congestion, reliability=reliability
            )
        self._put: Callable[[Any], None] = self._publisher.put
        if self.gid is not None:
            put, attach = self._publisher.put, Sequence(self.gid).next
            self._put = lambda data: put(data, attachment=attach())
        # types that can grow large (sequences) reuse one output buffer, under a lock
        self._buffer: EncodeBuffer | None = None
        self._lock = threading.Lock()
        definition = self.msg_type._definition
        if any(f.type.kind is not Kind.SCALAR for f in definition.fields) or any(
            f.type.is_nested for f in definition.fields
        ):
            self._buffer = EncodeBuffer()
        self._announce()
        owner._add(self)

    def write(self, message: Message) -> None:
        """Publish a message (rosR: ``ros.WriteMessage``)."""
        if type(message) is not self.msg_type:
            self._check_type(message)
        buffer = self._buffer
        if buffer is None:
            try:
                data = message._cdr_encode(message)
            except Exception:
                data = encode(message)  # raises the CdrError that names the field
            self._put(data)
            return
        with self._lock:
            try:
                data = message._cdr_encode(message, buffer.join)
            except Exception:
                data = encode(message)
            self._put(data)

    publish = write

    def write_raw(self, data: bytes | bytearray) -> None:
        """Publish CDR bytes (4-byte header included) as they are."""
        self._put(bytes(data) if isinstance(data, memoryview) else data)

    def _check_type(self, message: object) -> None:
        if getattr(message, '__msgtype__', None) != self.type_name:
            got = getattr(message, '__msgtype__', type(message).__name__)
            raise TypeError(f'the publisher on {self.topic} sends {self.type_name}, not {got}')

    @property
    def has_subscribers(self) -> bool:
        """Whether a subscriber (or a bridge route) currently matches this publisher's key.

        Transient-local publishers cannot tell: they report True.
        """
        status = getattr(self._publisher, 'matching_status', None)
        return True if status is None else bool(status.matching)

    def wait_for_subscribers(self, timeout: float = 5.0) -> bool:
        """Wait until ``has_subscribers`` (a message put right after a subscriber appears may
        otherwise be lost); returns whether one showed up in time."""
        deadline = time.monotonic() + timeout
        delay = 0.0005
        while not self.has_subscribers:
            if time.monotonic() >= deadline:
                return False
            time.sleep(delay)
            delay = min(delay * 2, 0.02)
        return True

    def close(self) -> None:
        """Withdraw the publisher from the network."""
        if self._closed:
            return
        self._closed = True
        self._withdraw()
        if not self.node.transport.closed:
            self._publisher.undeclare()
        self.node._remove(self)

    def __repr__(self) -> str:
        return f'<zros Publisher {self.topic} [{self.type_name}] {self.qos}>'


class Subscriber(_Entity):
    """Receives messages of one type on one topic (rosR: ``ros.Subscriber``).

    Poll it (``has_new_message``, ``read_message``, ``take``), give it a ``callback`` that runs
    when the node spins, or iterate it with ``async for``. It holds up to ``qos.depth`` unread
    messages (keep-last drops the oldest); a keep-all subscriber holds up to ``max_queue`` and
    then makes reliable publishers wait.
    """

    kind = EntityKind.SUBSCRIBER

    def __init__(
        self,
        topic: str,
        msg_type: str | type[Message],
        callback: Callable[[Any], object] | None = None,
        qos: QoSLike | None = None,
        *,
        node: Node | None = None,
        raw: bool = False,
        max_queue: int = KEEP_ALL_LIMIT,
        announce: bool = True,
    ) -> None:
        owner = _node(node)
        owner._check_open()
        super().__init__(owner, topic, msg_type, qos, announce)
        self._callback = callback
        self.raw = raw
        self._limit = max_queue if self.qos.keep_all else None
        self._queue: collections.deque[Any] = collections.deque(
            maxlen=None if self.qos.keep_all else self.qos.depth
        )
        self._scheduled = False
        self._arrived = Signal()  #: threads waiting for a message
        self._room = Signal()  #: a keep-all publisher thread waiting for room
        self._async_wakers: list[Callable[[], None]] = []
        self._last: Any = None
        self.received = 0  #: samples received so far
        self.dropped = 0  #: samples that did not decode
        self._bad_sources: set[str] = set()
        self.unattached = 0  #: rmw_zenoh: samples dropped for want of a valid attachment
        session = owner.transport.session
        on_sample = self._on_sample if self.gid is None else self._on_attached_sample
        if self.qos.transient_local:
            from zenoh import ext

            history = ext.HistoryConfig(detect_late_publishers=True, max_samples=self.qos.depth)
            recovery = None
            if self.gid is not None and self.qos.reliable:  # as rmw_zenoh subscriptions do
                recovery = ext.RecoveryConfig(periodic_queries=None, heartbeat=True)
            self._subscriber: Any = ext.declare_advanced_subscriber(
                session, self.key, on_sample, history=history, recovery=recovery,
                subscriber_detection=self.gid is not None or None,
            )  # fmt: skip
        else:
            self._subscriber = session.declare_subscriber(self.key, on_sample)
        self._announce()
        owner._add(self)

    # --- on Zenoh's thread -------------------------------------------------------------------

    def _on_attached_sample(self, sample: Any) -> None:
        """rmw_zenoh drops samples without a valid attachment; so does zros (logged once)."""
        if has_attachment(sample):
            self._on_sample(sample)
            return
        self.unattached += 1
        if self.unattached == 1:
            _log.warning(
                'dropped a message on %s without a valid rmw_zenoh attachment, as rmw_zenoh '
                'does (reported once per subscriber)',
                self.topic,
            )

    def _on_sample(self, sample: Any) -> None:
        queue = self._queue
        if self._limit is not None and len(queue) >= self._limit:
            self._wait_for_room()
        queue.append(sample)
        self.received += 1
        if self._callback is not None:
            self.node._executor.schedule(self)
        if self._arrived:
            self._arrived.notify()
        for waker in self._async_wakers:
            waker()

    def _has_room(self) -> bool:
        return len(self._queue) < (self._limit or 0) or self._closed

    def _wait_for_room(self) -> None:
        started = time.monotonic()
        warned = False
        while not self._has_room():
            self._room.wait(self._has_room, 0.5)
            if not warned and time.monotonic() - started > 2:
                warned = True
                _log.warning(
                    'subscriber on %s holds %d unread messages: its publishers wait',
                    self.topic,
                    len(self._queue),
                )

    # --- reading ---------------------------------------------------------------------------

    def _convert(self, sample: Any) -> Any:
        data = sample.payload.to_bytes()
        if self.raw:
            return data
        try:
            return decode(self.msg_type, data)
        except CdrError as exc:
            self.dropped += 1
            timestamp = sample.timestamp
            source = str(timestamp).rpartition('/')[2] if timestamp is not None else 'unknown'
            if source not in self._bad_sources and len(self._bad_sources) < _BAD_SOURCES_LIMIT:
                self._bad_sources.add(source)
                _log.warning(
                    'dropped a message on %s from the session %s (reported once per session): %s',
                    self.topic,
                    source,
                    exc,
                )
            return None

    def _drain(self) -> list[Any]:
        queue = self._queue
        samples = []
        popleft = queue.popleft
        try:
            while True:
                samples.append(popleft())
        except IndexError:
            pass
        if self._room:
            self._room.notify()
        return samples

    def has_new_message(self) -> bool:
        """Whether a message arrived since the last ``read_message`` or ``take``."""
        return bool(self._queue)

    def read_message(self) -> Any:
        """The newest message (rosR: ``ros.ReadMessage``); unread older ones are discarded.

        Returns the last message read again when nothing new came, and None before the first.
        """
        for sample in reversed(self._drain()):
            message = self._convert(sample)
            if message is not None:
                self._last = message
                break
        return self._last

    def take(self, max_messages: int | None = None) -> list[Any]:
        """Every unread message, oldest first (up to ``max_messages``)."""
        if max_messages is None:
            samples = self._drain()
        else:
            samples = []
            popleft = self._queue.popleft
            for _ in range(max_messages):
                try:
                    samples.append(popleft())
                except IndexError:
                    break
        messages = [m for m in map(self._convert, samples) if m is not None]
        if messages:
            self._last = messages[-1]
        return messages

    def _has_message(self) -> bool:
        return bool(self._queue) or self._closed

    def wait_for_message(self, timeout: float | None = None) -> Any:
        """Block until a message is unread, then return the oldest one (None on timeout)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            messages = self.take(1)
            if messages:
                return messages[0]
            remaining = None if deadline is None else deadline - time.monotonic()
            if self._closed or (remaining is not None and remaining <= 0):
                return None
            self._arrived.wait(self._has_message, remaining)

    def _dispatch(self) -> int:
        callback = self._callback
        if callback is None:
            return 0
        done = 0
        for message in self.take():
            try:
                callback(message)
            except Exception:
                _log.exception('callback %r of the subscriber on %s raised', callback, self.topic)
            done += 1
        return done

    async def __aiter__(self) -> AsyncIterator[Any]:
        """Messages as they arrive: ``async for message in subscriber``."""
        loop = asyncio.get_running_loop()
        event = asyncio.Event()

        def waker() -> None:
            loop.call_soon_threadsafe(event.set)

        self._async_wakers.append(waker)
        try:
            while not self._closed:
                event.clear()
                messages = self.take()
                if not messages:
                    await event.wait()
                    continue
                for message in messages:
                    yield message
        finally:
            self._async_wakers.remove(waker)

    # --- lifetime --------------------------------------------------------------------------

    def close(self) -> None:
        """Withdraw the subscriber from the network; queued messages stay readable."""
        if self._closed:
            return
        self._closed = True
        self._withdraw()
        if not self.node.transport.closed:
            self._subscriber.undeclare()
        self.node._remove(self)
        self._arrived.notify()
        self._room.notify()
        for waker in list(self._async_wakers):
            waker()

    def __repr__(self) -> str:
        return f'<zros Subscriber {self.topic} [{self.type_name}] {self.qos}>'
