"""Subscribers: samples kept raw in a bounded queue, decoded only when read.

Samples overwritten unread cost nothing. Reads never block; callbacks run when the node spins;
``async for`` works on the same queue.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
import time
from collections.abc import AsyncIterator, Callable
from typing import TYPE_CHECKING, Generic, Literal, NoReturn, TypedDict, TypeVar, cast, overload

from zenoh import Sample

from zros.cdr import CdrError
from zros.cdr.classes import compiled_decoder
from zros.cdr.message import M, Message, decode
from zros.cdr.registry import registry_of
from zros.keyexpr.kinds import EntityKind
from zros.pubsub.senders import describe_sender
from zros.pubsub.tail import Tail, can_be_large
from zros.pubsub.type_watch import forget_types, type_watch_of
from zros.qos import QoS, QoSLike, as_qos
from zros.runtime.defaults import NodeLike
from zros.runtime.drops import DropCounter, sender_key
from zros.runtime.entity import Entity, message_class
from zros.runtime.executor import Work
from zros.runtime.sample_queue import KEEP_ALL_BYTES, SampleQueue
from zros.runtime.signal import (
    Signal,
    add_interrupt_listener,
    interrupt_flag,
    interrupted,
    remove_interrupt_listener,
)

_log = logging.getLogger('zros')

if TYPE_CHECKING:
    import typing_extensions
    from typing_extensions import Unpack

    #: a message of its class, or CDR bytes when ``raw`` (a bare ``Subscriber`` is of Message)
    T = typing_extensions.TypeVar('T', bound=Message | bytes, default=Message)

    class SubscriberOptions(TypedDict, total=False):
        """The keyword-only settings of :class:`Subscriber` besides ``raw``."""

        node: NodeLike | None
        max_queue: int | None
        max_queue_bytes: int
        announce: bool
else:  # TypeVar's default= is Python 3.13's
    T = TypeVar('T', bound=Message | bytes)


class Subscriber(Entity, Generic[T]):
    """Receives messages of one type on one topic (rosR: ``ros.Subscriber``).

    Poll it (``has_new_message``, ``read_message``, ``take``), give it a ``callback`` that runs
    when the node spins, or iterate it with ``async for``. It holds up to ``qos.depth`` unread
    messages (keep-last drops the oldest). A keep-all subscriber holds every unread message up
    to ``max_queue_bytes`` (256 MiB: payloads plus some 384 bytes each) and, if given,
    ``max_queue`` messages; past that it drops new ones, counted in ``dropped`` and logged,
    and never holds up its publishers or the rest of the process (``max_queue`` with a
    keep-last QoS is a ValueError: it would not be used).

    Messages that do not decode (or, under rmw_zenoh, come without a valid attachment) are
    dropped, counted per sender (:meth:`dropped_by_sender`) and logged, at most once per sender
    every 10 s; they never count as new. With ``qos.lifespan`` (seconds), messages older than
    that when they arrive (by the Zenoh timestamp of their sender, or of the first router on
    their way) are dropped too, counted in ``expired`` and logged the same way.

    Two ways to read: ``read_message`` reads the newest state (rosR), ``take`` and
    ``wait_for_message`` read the stream, oldest unread first, each message once.

    The module-level way: ``(topic, type)`` is rosR's order, ``node`` None the default node of
    ``zros.init``. ``node.create_subscription(type, topic)`` takes rclpy's order; both are on
    purpose.

    Generic: ``Subscriber(topic, String)`` is a ``Subscriber[String]`` (callback, reads and
    ``async for`` give ``String``); a type name gives ``Subscriber[Message]``, ``raw=True`` bytes.
    """

    gid: bytes | None  #: rmw_zenoh: the GID in its token's hash

    @overload
    def __init__(
        self: Subscriber[Message],
        topic: str,
        msg_type: str,
        callback: Callable[[Message], object] | None = None,
        qos: QoSLike | None = None,
        *,
        raw: Literal[False] = False,
        **options: Unpack[SubscriberOptions],
    ) -> None: ...

    @overload
    def __init__(
        self: Subscriber[M],
        topic: str,
        msg_type: type[M],
        callback: Callable[[M], object] | None = None,
        qos: QoSLike | None = None,
        *,
        raw: Literal[False] = False,
        **options: Unpack[SubscriberOptions],
    ) -> None: ...

    @overload
    def __init__(
        self: Subscriber[bytes],
        topic: str,
        msg_type: str | type[Message],
        callback: Callable[[bytes], object] | None = None,
        qos: QoSLike | None = None,
        *,
        raw: Literal[True],
        **options: Unpack[SubscriberOptions],
    ) -> None: ...

    @overload
    def __init__(
        self: Subscriber[Message | bytes],
        topic: str,
        msg_type: str | type[Message],
        callback: Callable[[Message | bytes], object] | None = None,
        qos: QoSLike | None = None,
        *,
        raw: bool,
        **options: Unpack[SubscriberOptions],
    ) -> None: ...

    def __init__(
        self,
        topic: str,
        msg_type: str | type[Message],
        callback: Callable[[NoReturn], object] | None = None,  # T: see the overloads
        qos: QoSLike | None = None,
        *,
        node: NodeLike | None = None,
        raw: bool = False,
        max_queue: int | None = None,
        max_queue_bytes: int = KEEP_ALL_BYTES,
        announce: bool = True,
    ) -> None:
        super().__init__(node)
        context = self.context
        self.msg_type = message_class(context.registry, msg_type)
        self.type_name = self.msg_type.__msgtype__
        self.qos: QoS = as_qos(qos)
        if max_queue is not None and not self.qos.keep_all:
            raise ValueError(
                f'max_queue bounds a keep-all subscriber; this one keeps the last '
                f'{self.qos.depth} messages, so it would not be used: pass qos="keep_all" with '
                'it, or leave it out'
            )
        self.topic = self._resolve(EntityKind.SUBSCRIBER, topic)
        wire = self._place(
            EntityKind.SUBSCRIBER, self.topic, self.type_name, registry_of(self.msg_type),
            qos=self.qos, announce=announce, own=True,
        )  # fmt: skip
        self._callback = cast('Callable[[T], object] | None', callback)  # see the overloads
        self.raw = raw
        self._queue = SampleQueue(
            None if self.qos.keep_all else self.qos.depth, max_queue, max_queue_bytes
        )
        self._reading = threading.Lock()  #: one reader at a time
        self._checked: Sample | None = None  #: the sample has_new_message decoded, and its message
        self._checked_message: T | None = None
        #: the type's compiled decoder, once a batch came
        self._decoder: Callable[[bytes, bool], T] | None = None
        self._work = Work(self._deliver)
        self._executor = context.executor
        self._schedule = context.executor.schedule
        #: immediate callbacks: samples are decoded and handed to the callback as they arrive
        self._now = callback is not None and context.executor.immediate
        self._arrived = Signal()  #: threads waiting for a message
        self._async_wakers: list[Callable[[], None]] = []
        self._last: T | None = None
        self.undecodable = 0  #: samples that did not decode as the type
        self._drops = DropCounter(self.topic)
        self._overflows = DropCounter(self.topic)
        self.expired = 0  #: messages dropped on arrival, older than ``qos.lifespan``
        self._lifespan = self.qos.lifespan
        self._expiries = DropCounter(self.topic)
        self._rejection = wire.rejection
        #: reliable: asks for the newest large message once a stream pauses (pubsub.tail)
        self._tail: Tail | None = None
        if self.qos.reliable and can_be_large(self.msg_type):
            self._tail = Tail(context.transport, self.key, self._admit)
        batches = self._admit if self._tail is None else self._on_samples
        self._subscribe(wire, self.qos, batches=batches, rejected=self._on_rejected)
        if announce:  # before its tokens: the check warns from this side, before it returns
            type_watch_of(context.transport).watch(
                self, EntityKind.SUBSCRIBER, self.topic, self.type_name
            )
        self._announce()

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
        """Messages lost: past a keep-all queue's bounds, undecodable, (rmw_zenoh) without
        a valid attachment, or past their lifespan (``expired``). Keep-last replacing unread
        messages is not counted."""
        return self.overflowed + self.undecodable + self.unattached + self.expired

    def dropped_by_sender(self) -> dict[str, int]:
        """Undecodable and unattached messages by sender (as the warnings name them)."""
        return self._drops.counts()

    # --- on the delivery thread (Zenoh's for transient local) ---------------------------

    def _on_rejected(self, sample: Sample) -> None:
        """The wire turned ``sample`` away (rmw_zenoh: no valid attachment)."""
        self._queue.reject()
        self._drop(sample, self._rejection)

    @property
    def recovered(self) -> int:
        """Newest messages that a slow link had dropped, fetched once their stream paused
        (counted in ``received`` too)."""
        return 0 if self._tail is None else self._tail.recovered

    def _on_samples(self, samples: list[Sample]) -> None:
        """Live samples of a subscriber that follows its large ones."""
        assert self._tail is not None
        self._tail.seen(samples)
        self._admit(samples)

    def _admit(self, samples: list[Sample]) -> None:
        if self._lifespan is not None:
            samples = self._unexpired(samples, self._lifespan)
            if not samples:
                return
        if self._now and not self._executor.stopped:
            self._deliver(self._queue.passing(samples))
            return
        refused = self._queue.put(samples)
        for _ in range(refused):
            self._overflows.add('queue', lambda: '', self._queue.describe_full)
        if refused == len(samples):
            return
        if self._callback is not None:
            self._schedule(self._work)
        if self._arrived.waiters:
            self._arrived.notify()
        for waker in self._async_wakers:
            waker()

    def _unexpired(self, samples: list[Sample], lifespan: float) -> list[Sample]:
        """``samples`` but those older than ``lifespan``, which are counted and logged (a
        sample without a timestamp cannot tell its age: it is kept)."""
        now = time.time()
        kept = []
        for sample in samples:
            stamp = sample.timestamp
            age = 0.0 if stamp is None else now - stamp.get_time_as_ntp64().as_secs_f64()
            if age <= lifespan:
                kept.append(sample)
                continue
            self.expired += 1
            reason = f'it arrived {age:.2f} s old, past its lifespan of {lifespan:g} s'
            self._drop(sample, reason, self._expiries)
        return kept

    def _drop(self, sample: Sample, reason: str, counter: DropCounter | None = None) -> None:
        key = sender_key(sample)
        counter = self._drops if counter is None else counter
        counter.add(key, lambda: describe_sender(sample, key, self.context, self.topic), reason)

    # --- reading ---------------------------------------------------------------------------

    def _convert(self, sample: Sample) -> T | None:
        if sample is self._checked:
            message = self._checked_message
            self._checked = self._checked_message = None
            return message
        data = sample.payload.to_bytes()
        # T is bytes when raw, else msg_type's instances (the overloads of __init__)
        if self.raw:
            return data  # type: ignore[return-value]  # T is bytes (see above)
        try:
            return decode(self.msg_type, data)  # type: ignore[return-value]  # T is msg_type
        except CdrError as exc:
            self.undecodable += 1  # under self._reading
            self._drop(sample, f'it does not decode as {self.type_name}: {exc}')
            return None

    def _convert_all(self, samples: list[Sample]) -> list[T]:
        """The messages of ``samples`` (under ``self._reading``), dropping the undecodable."""
        if self.raw:
            return [m for m in map(self._convert, samples) if m is not None]
        fast = self._decoder
        if fast is None:
            fast = self._decoder = cast(
                'Callable[[bytes, bool], T]', compiled_decoder(self.msg_type)
            )
        checked = self._checked  # decoded already by has_new_message
        messages: list[T] = []
        append = messages.append
        for sample in samples:
            if sample is checked:
                message = self._checked_message
                assert message is not None  # set with self._checked
                append(message)
                self._checked = self._checked_message = checked = None
                continue
            try:
                append(fast(sample.payload.to_bytes(), False))
            except Exception:  # malformed: the checked path explains, counts and logs the drop
                message = self._convert(sample)
                if message is not None:
                    append(message)
        return messages

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

    def read_message(self) -> T | None:
        """The newest message (rosR: ``ros.ReadMessage``); unread older ones are discarded.

        Returns the last message read again when nothing new came, and None before the first.
        The state read (the latest value); :meth:`take` and :meth:`wait_for_message` read the
        stream, oldest first.
        """
        with self._reading:
            for sample in reversed(self._queue.pop()):
                message = self._convert(sample)
                if message is not None:
                    self._last = message
                    break
            self._checked = self._checked_message = None
        return self._last

    def take(self, max_messages: int | None = None) -> list[T]:
        """Every unread message, oldest first (up to ``max_messages``): the stream read."""
        messages: list[T] = []
        with self._reading:
            while max_messages is None or len(messages) < max_messages:
                samples = self._queue.pop(
                    None if max_messages is None else max_messages - len(messages)
                )
                if not samples:
                    break
                messages.extend(self._convert_all(samples))
                if max_messages is None:
                    break
        if messages:
            self._last = messages[-1]
        return messages

    def _has_message(self) -> bool:
        return self._queue.unread() > 0 or self._closed

    def wait_for_message(self, timeout: float | None = None) -> T | None:
        """Block until a message is unread, then return the oldest one (None on timeout, once
        the subscriber is closed, and after Ctrl-C).

        A stream read like :meth:`take` (each message once, in order, as rospy's and rclpy's
        ``wait_for_message`` give the next one); :meth:`read_message` is the state read.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            remaining = None if deadline is None else deadline - time.monotonic()
            if self._closed or interrupt_flag.value or (remaining is not None and remaining <= 0):
                messages = self.take(1)  # a last look
                return messages[0] if messages else None
            # returns at once when a message is there: no take() before it (a blocking read
            # with cold caches spent a few microseconds on the empty one); take(1), inlined
            # (each call on this path costs every round trip a few microseconds cold)
            self._arrived.wait(self._has_message, remaining, interruptible=True)
            with self._reading:
                messages = self._convert_all(self._queue.pop(1))
            if messages:  # else a spurious wake-up, or a sample that did not decode
                self._last = messages[0]
                return messages[0]

    def _deliver(self, samples: list[Sample] | None = None) -> int:
        """Run the callback on each message of ``samples`` that decodes (the last becomes
        ``read_message``'s); returns how many ran. The executor's work (``samples`` None:
        every unread one, what ``take()`` does in fewer calls), or the delivery thread's with
        immediate callbacks. It runs once per delivered batch: each call added here costs
        every round trip."""
        if samples is None:
            samples = self._queue.pop()
        with self._reading:
            messages = self._convert_all(samples)
        if not messages:
            return 0
        self._last = messages[-1]
        callback = self._callback
        assert callback is not None
        done = 0
        for message in messages:
            try:
                callback(message)
            except Exception:  # a user callback: logged, the others still run
                _log.exception('callback %r of the subscriber on %s raised', callback, self.topic)
            done += 1
        return done

    async def __aiter__(self) -> AsyncIterator[T]:
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
        super().close()

    def _on_close(self) -> None:
        self._executor.cancel(self._work)
        forget_types(self)
        if self._tail is not None:
            self._tail.close()
        self._drops.flush()
        self._overflows.flush()
        self._expiries.flush()
        self._arrived.notify()
        for waker in list(self._async_wakers):
            waker()

    def __repr__(self) -> str:
        return f'<zros Subscriber {self.topic} [{self.type_name}] {self.qos}>'
