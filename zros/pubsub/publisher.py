"""Publishers: messages of one type on one topic, encoded once and put on Zenoh."""

from __future__ import annotations

import functools
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Generic, Protocol, cast, overload

from zenoh import CongestionControl, Priority, Reliability, ZError, ext

from zros.cdr import encode
from zros.cdr.encode_buffer import EncodeBuffer
from zros.cdr.message import M, Message
from zros.cdr.registry import registry_of
from zros.keyexpr.kinds import EntityKind
from zros.pubsub.tail import Newest, can_be_large
from zros.pubsub.type_watch import forget_types, type_watch_of
from zros.qos import Congestion, QoS, QoSLike, as_qos
from zros.runtime.defaults import NodeLike
from zros.runtime.entity import Entity, message_class
from zros.runtime.signal import sleep
from zros.transport.zenoh_qos import CONGESTION, PRIORITY

if TYPE_CHECKING:
    from zenoh import Publisher as ZenohPublisher
    from zenoh import Timestamp

    from zros.wire import WireEntity
    from zros.wire.base import Put


class _TimedPut(Protocol):
    """A Zenoh publisher's ``put`` given a timestamp."""

    def __call__(
        self, payload: bytes | bytearray, *, attachment: bytes | None, timestamp: Timestamp | None
    ) -> None: ...


class _DeclarePublisher(Protocol):
    """``session.declare_publisher``, or zenoh-ext's advanced one bound to the session."""

    def __call__(
        self,
        key_expr: str,
        /,
        *,
        congestion_control: CongestionControl,
        reliability: Reliability,
        priority: Priority,
        express: bool,
    ) -> ZenohPublisher | ext.AdvancedPublisher: ...


class Publisher(Entity, Generic[M]):
    """Publishes messages of one type on one topic (rosR: ``ros.Publisher``).

    ``qos`` is a :class:`zros.QoS`, a depth or a preset name (``'sensor_data'``). When the
    network cannot keep up, ``write()`` drops the message rather than wait (a keep-last reader
    wants the newest), except for reliable keep-all publishers, which block until it is sent
    (as rmw_zenoh chooses); ``QoS(congestion=...)`` overrides that.

    The module-level way: ``(topic, type)`` is rosR's order, ``node`` None the default node of
    ``zros.init``. ``node.create_publisher(type, topic)`` takes rclpy's order; both are on purpose.

    Generic in its message class: ``Publisher(topic, String)`` is a ``Publisher[String]``, whose
    ``write`` takes a ``String``; given a type name it is a ``Publisher[Message]``.
    """

    gid: bytes | None  #: rmw_zenoh: the GID in its attachments (and its token's hash)
    msg_type: type[M]  #: its message class

    @overload
    def __init__(
        self: Publisher[Message],
        topic: str,
        msg_type: str,
        qos: QoSLike | None = None,
        *,
        node: NodeLike | None = None,
        announce: bool = True,
    ) -> None: ...

    @overload
    def __init__(
        self,
        topic: str,
        msg_type: type[M],
        qos: QoSLike | None = None,
        *,
        node: NodeLike | None = None,
        announce: bool = True,
    ) -> None: ...

    def __init__(
        self,
        topic: str,
        msg_type: str | type[M],
        qos: QoSLike | None = None,
        *,
        node: NodeLike | None = None,
        announce: bool = True,
    ) -> None:
        super().__init__(node)
        context = self.context
        # a type name's class is a Message (the first overload), a class is itself
        self.msg_type = cast('type[M]', message_class(context.registry, msg_type))
        self.type_name = self.msg_type.__msgtype__
        self.qos: QoS = as_qos(qos)
        self.topic = self._resolve(EntityKind.PUBLISHER, topic)
        wire = self._place(
            EntityKind.PUBLISHER, self.topic, self.type_name, registry_of(self.msg_type),
            qos=self.qos, announce=announce, own=True,
        )  # fmt: skip
        self._publisher = self._keep(self._declare(wire))
        # types that can grow large (sequences) reuse an output buffer while their messages are
        # large, holding _in_use while they do; small ones are joined into fresh bytes (faster
        # for them) and put with no lock: close() swaps _put first, then waits for a put still
        # running (zenoh-python refuses to undeclare a publisher another thread is inside).
        self._buffers: tuple[EncodeBuffer, ...] = ()
        self._turn = 0  #: the buffer the next large message goes to
        self._large = sys.maxsize  #: messages from this size on go through a buffer
        self._small = True  #: the last message was small
        #: the newest large message, for subscribers whose slow link dropped it (pubsub.tail)
        self._newest: Newest | None = None
        put: Put = self._publisher.put
        if can_be_large(self.msg_type):
            self._buffers = (EncodeBuffer(),)
            self._large = self._buffers[0].threshold
            if self._keeps_newest():
                # the newest is kept in one buffer while the next message goes to the other
                self._buffers += (EncodeBuffer(),)
                put = self._stamped(self._publisher.put)
        self._put: Callable[[bytes | bytearray], None] = wire.sender(put)
        if announce:  # before its tokens: the check warns from this side, before it returns
            type_watch_of(context.transport).watch(
                self, EntityKind.PUBLISHER, self.topic, self.type_name
            )
        self._announce()

    def _declare(self, wire: WireEntity) -> ZenohPublisher | ext.AdvancedPublisher:
        qos = self.qos
        congestion = CONGESTION[qos.congestion_control]
        reliability = Reliability.RELIABLE if qos.reliable else Reliability.BEST_EFFORT
        priority, express = qos.priority_for(self.topic, self.type_name)
        #: the Zenoh priority and express flag its messages carry
        self.priority, self.express = priority, express
        session = self.context.transport.session
        declare: _DeclarePublisher = session.declare_publisher
        if qos.transient_local:  # zenoh-ext's, which keeps the last messages for late joiners
            declare = functools.partial(
                ext.declare_advanced_publisher, session,
                cache=ext.CacheConfig(max_samples=qos.depth), publisher_detection=True,
                **wire.publisher_options(qos),
            )  # fmt: skip
        return declare(
            self.key, congestion_control=congestion, reliability=reliability,
            priority=PRIORITY[priority], express=express,
        )  # fmt: skip

    @property
    def resent(self) -> int:
        """Newest messages sent again, each to one subscriber whose slow link had dropped it
        (:mod:`zros.pubsub.tail`)."""
        return 0 if self._newest is None else self._newest.sent

    def _keeps_newest(self) -> bool:
        """Whether it keeps its newest large message: a reliable keep-last publisher of the
        volatile kind (transient local ones have zenoh-ext's cache; keep-all ones block)."""
        qos = self.qos
        return (
            qos.reliable
            and not qos.transient_local
            and qos.congestion_control is not Congestion.BLOCK
        )

    def _stamped(self, put: _TimedPut) -> Put:
        """``put`` with the timestamp :class:`~zros.pubsub.tail.Newest` gives each payload."""
        newest = self._newest = Newest(
            self.context.transport.session, self.key, PRIORITY[self.priority]
        )
        stamp = newest.stamp

        def stamped(payload: bytes | bytearray, *, attachment: bytes | None = None) -> None:
            put(payload, attachment=attachment, timestamp=stamp(payload))

        return stamped

    def write(self, message: M) -> None:
        """Publish a message (rosR: ``ros.WriteMessage``)."""
        if type(message) is not self.msg_type:
            self._check_type(message)
        if self._small:
            try:
                data = message._cdr_encode(message)
            except Exception:  # the fast encoder failed: the checked one names the field
                data = encode(message)
            if len(data) >= self._large:
                self._small = False  # the next ones go through the buffer
            self._put(data)
            return
        buffers = self._buffers
        with self._in_use:  # the buffer is chosen under it too: one writer at a time per buffer
            buffer = buffers[self._turn]
            self._turn = (self._turn + 1) % len(buffers)
            try:
                data = message._cdr_encode(message, buffer.join)
            except Exception:  # the fast encoder failed: the checked one names the field
                data = encode(message)
            if len(data) < self._large:
                self._small = True
            self._put(data)

    #: rclpy's name (``write`` is rosR's ``ros.WriteMessage``)
    publish = write

    def write_raw(self, data: bytes | bytearray) -> None:
        """Publish CDR bytes (4-byte header included) as they are."""
        if type(data) is not bytes and (isinstance(data, memoryview) or self._newest is not None):
            data = bytes(data)  # the newest is kept: not a buffer its owner may change
        self._put(data)

    def close(self) -> None:
        """Withdraw it from the network; safe to call twice. Later writes raise ``zenoh.ZError``."""
        self._put = self._refuse
        forget_types(self)
        if self._newest is not None:
            self._newest.close()
        super().close()

    def _refuse(self, data: bytes | bytearray) -> None:
        raise ZError(f'the publisher on {self.topic} is closed')

    def _check_type(self, message: object) -> None:
        if getattr(message, '__msgtype__', None) != self.type_name:
            got = getattr(message, '__msgtype__', type(message).__name__)
            raise TypeError(f'the publisher on {self.topic} sends {self.type_name}, not {got}')

    @property
    def has_subscribers(self) -> bool:
        """Whether a subscriber (or a bridge route) currently matches this publisher's key.

        Transient-local publishers cannot tell: they report True. A closed one reports False.
        """
        with self._in_use:
            if self._closed:
                return False
            status = getattr(self._publisher, 'matching_status', None)
            return True if status is None else bool(status.matching)

    def wait_for_subscribers(self, timeout: float | None = 5.0) -> bool:
        """Wait until ``has_subscribers`` (a message put right after a subscriber appears may
        otherwise be lost); returns whether one showed up in time (False after Ctrl-C)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        delay = 0.0005
        while not self.has_subscribers:
            if self._closed:
                return False
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return False
            if not sleep(delay if remaining is None else min(delay, remaining)):
                return False
            delay = min(delay * 2, 0.02)
        return True

    def __repr__(self) -> str:
        return f'<zros Publisher {self.topic} [{self.type_name}] {self.qos}>'
