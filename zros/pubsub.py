"""Publishers and subscribers on Zenoh keys of zenoh-bridge-ros2dds.

A subscriber keeps received samples as raw Zenoh payloads in a queue bounded by its QoS depth,
and decodes them only when read: samples overwritten unread cost nothing. Reads never block;
callbacks run when the node spins; ``async for`` works on the same queue.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from collections.abc import AsyncIterator, Callable
from typing import TYPE_CHECKING, Any

from zros.cdr import CdrError, encode
from zros.cdr.message import EncodeBuffer, Message, decode
from zros.cdr.model import Kind
from zros.keyexpr.kinds import EntityKind
from zros.qos import QoS, QoSLike, as_qos
from zros.runtime.drops import DropCounter, describe_sender, sender_key
from zros.runtime.sample_queue import KEEP_ALL_BYTES, SampleQueue
from zros.runtime.signal import (
    Signal,
    add_interrupt_listener,
    interrupted,
    remove_interrupt_listener,
    sleep,
)
from zros.wire import Sequence, entity_wire, has_attachment

if TYPE_CHECKING:
    from zros.node import Node

_log = logging.getLogger('zros')


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

    def wait_for_subscribers(self, timeout: float | None = 5.0) -> bool:
        """Wait until ``has_subscribers`` (a message put right after a subscriber appears may
        otherwise be lost); returns whether one showed up in time (False after Ctrl-C)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        delay = 0.0005
        while not self.has_subscribers:
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return False
            if not sleep(delay if remaining is None else min(delay, remaining)):
                return False
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
    messages (keep-last drops the oldest). A keep-all subscriber holds every unread message up
    to ``max_queue_bytes`` (256 MiB: payloads plus some 384 bytes each) and, if given,
    ``max_queue`` messages; past that it drops new ones, counted in ``dropped`` and logged,
    and never holds up its publishers or the rest of the process.

    Messages that do not decode (or, under rmw_zenoh, come without a valid attachment) are
    dropped, counted per sender (:meth:`dropped_by_sender`) and logged, at most once per sender
    every 10 s; they never count as new.
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
        max_queue: int | None = None,
        max_queue_bytes: int = KEEP_ALL_BYTES,
        announce: bool = True,
    ) -> None:
        owner = _node(node)
        owner._check_open()
        super().__init__(owner, topic, msg_type, qos, announce)
        self._callback = callback
        self.raw = raw
        self._queue = SampleQueue(
            None if self.qos.keep_all else self.qos.depth, max_queue, max_queue_bytes
        )
        self._reading = threading.Lock()  #: one reader at a time
        self._checked: Any = None  #: the sample has_new_message decoded, and its message
        self._checked_message: Any = None
        self._scheduled = False
        self._arrived = Signal()  #: threads waiting for a message
        self._async_wakers: list[Callable[[], None]] = []
        self._last: Any = None
        self.undecodable = 0  #: samples that did not decode as the type
        self._drops = DropCounter(self.topic)
        self._overflows = DropCounter(self.topic)
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

    @property
    def received(self) -> int:
        """Samples that reached the subscription so far (dropped ones included)."""
        return self._queue.received

    @property
    def overflowed(self) -> int:
        """Keep-all: samples dropped past the queue's bounds."""
        return self._queue.overflowed

    @property
    def unattached(self) -> int:
        """rmw_zenoh: samples dropped for want of a valid attachment."""
        return self._queue.rejected

    @property
    def dropped(self) -> int:
        """Messages lost: past a keep-all queue's bounds, undecodable, or (rmw_zenoh) without
        a valid attachment. Keep-last replacing unread messages is not counted."""
        return self.overflowed + self.undecodable + self.unattached

    def dropped_by_sender(self) -> dict[str, int]:
        """Undecodable and unattached messages by sender (as the warnings name them)."""
        return self._drops.counts()

    # --- on Zenoh's thread -------------------------------------------------------------------

    def _on_attached_sample(self, sample: Any) -> None:
        """rmw_zenoh drops samples without a valid attachment; so does zros."""
        if has_attachment(sample):
            self._on_sample(sample)
            return
        self._queue.reject()
        self._drop(sample, 'it has no valid rmw_zenoh attachment (rmw_zenoh drops such messages)')

    def _on_sample(self, sample: Any) -> None:
        if not self._queue.put(sample):
            self._overflows.add('queue', lambda: '', self._queue.describe_full)
            return
        if self._callback is not None:
            self.node._executor.schedule(self)
        if self._arrived:
            self._arrived.notify()
        for waker in self._async_wakers:
            waker()

    def _drop(self, sample: Any, reason: str) -> None:
        key = sender_key(sample)
        self._drops.add(key, lambda: describe_sender(sample, key, self.node, self.topic), reason)

    # --- reading ---------------------------------------------------------------------------

    def _convert(self, sample: Any) -> Any:
        if sample is self._checked:
            message = self._checked_message
            self._checked = self._checked_message = None
            return message
        data = sample.payload.to_bytes()
        if self.raw:
            return data
        try:
            return decode(self.msg_type, data)
        except CdrError as exc:
            self.undecodable += 1  # under self._reading
            self._drop(sample, f'it does not decode as {self.type_name}: {exc}')
            return None

    def has_new_message(self) -> bool:
        """Whether a message arrived since the last ``read_message`` or ``take``.

        It decodes the newest unread sample to be sure (``read_message`` then returns it
        without decoding again): samples that do not decode are dropped here and never make
        it true.
        """
        queue = self._queue
        if self.raw or not queue:
            return bool(queue)
        with self._reading:
            while (sample := queue.newest()) is not None:
                if sample is self._checked:
                    return True
                message = self._convert(sample)
                if message is not None:
                    self._checked, self._checked_message = sample, message
                    return True
                queue.discard(sample)
            return False

    def read_message(self) -> Any:
        """The newest message (rosR: ``ros.ReadMessage``); unread older ones are discarded.

        Returns the last message read again when nothing new came, and None before the first.
        """
        with self._reading:
            for sample in reversed(self._queue.pop()):
                message = self._convert(sample)
                if message is not None:
                    self._last = message
                    break
            self._checked = self._checked_message = None
        return self._last

    def take(self, max_messages: int | None = None) -> list[Any]:
        """Every unread message, oldest first (up to ``max_messages``)."""
        messages: list[Any] = []
        with self._reading:
            while max_messages is None or len(messages) < max_messages:
                samples = self._queue.pop(
                    None if max_messages is None else max_messages - len(messages)
                )
                if not samples:
                    break
                messages.extend(m for m in map(self._convert, samples) if m is not None)
                if max_messages is None:
                    break
        if messages:
            self._last = messages[-1]
        return messages

    def _has_message(self) -> bool:
        return bool(self._queue) or self._closed

    def wait_for_message(self, timeout: float | None = None) -> Any:
        """Block until a message is unread, then return the oldest one (None on timeout, once
        the subscriber is closed, and after Ctrl-C)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            messages = self.take(1)
            if messages:
                return messages[0]
            remaining = None if deadline is None else deadline - time.monotonic()
            if self._closed or interrupted() or (remaining is not None and remaining <= 0):
                return None
            self._arrived.wait(self._has_message, remaining, interruptible=True)

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
        """Messages as they arrive: ``async for message in subscriber`` (ends on close and
        on Ctrl-C)."""
        loop = asyncio.get_running_loop()
        event = asyncio.Event()

        def waker() -> None:
            with contextlib.suppress(RuntimeError):  # the loop closed
                loop.call_soon_threadsafe(event.set)

        self._async_wakers.append(waker)
        add_interrupt_listener(waker)
        try:
            while not (self._closed or interrupted()):
                event.clear()
                messages = self.take()
                if not messages:
                    await event.wait()
                    continue
                for message in messages:
                    yield message
        finally:
            remove_interrupt_listener(waker)
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
        self._drops.flush()
        self._overflows.flush()
        self._arrived.notify()
        for waker in list(self._async_wakers):
            waker()

    def __repr__(self) -> str:
        return f'<zros Subscriber {self.topic} [{self.type_name}] {self.qos}>'
