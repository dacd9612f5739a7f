"""Service clients: a call is a Zenoh query, waited for on the caller's thread.

``call`` waits on Zenoh's reply channel directly, so it works whether or not the caller's node
spins; the server's node must spin, so a call inside a callback of the node that serves it times
out (the error says why). ``call_async`` resolves a future that is also awaitable.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from zenoh import Reply
from zenoh.handlers import Callback, Handler

from zros.cdr import CdrError
from zros.cdr.interfaces import ServiceType
from zros.cdr.message import Message, decode, encode
from zros.keyexpr.kinds import EntityKind
from zros.qos import SERVICE_PRIORITY
from zros.runtime.defaults import NodeLike
from zros.runtime.futures import ServiceFuture
from zros.runtime.signal import Signal, raises_on_interrupt
from zros.runtime.timeouts import UNSET, Unset, either_timeout
from zros.services.errors import (
    ERROR_PREFIX,
    LinkLostError,
    ServiceCallError,
    ServiceError,
    ServiceTimeoutError,
    ServiceUnavailableError,
)
from zros.services.server import unanswered_here
from zros.services.service_entity import ServiceEntity
from zros.transport.zenoh_qos import PRIORITY

#: seconds a call may still wait for its answer once no server matches any more (the answer
#: may be in transit: declarations can overtake replies); then it ends as unavailable
GONE_GRACE = 2.0
#: seconds a call that ended without a reply, its server present when it was sent, waits to
#: hear whether the link dropped: Zenoh ends such queries a moment before it reports the drop
LINK_SETTLE = 1.0


class Client(ServiceEntity):
    """A service client (rclpy: ``node.create_client``).

    ``call(request)`` (or ``call(a=1, b=2)``) returns the response or raises
    :class:`ServiceUnavailableError` (no server), :class:`ServiceTimeoutError` or
    :class:`ServiceCallError` (the server failed). ``call_async`` returns a future to ``await``.
    A client is callable: ``client(request)`` is ``client.call(request)``.

    ``(name, type)`` as :class:`zros.Subscriber` takes them, ``node`` None the default node of
    ``zros.init``; ``node.create_client(type, name)`` takes rclpy's order. Both are on purpose.
    """

    gid: bytes | None  #: rmw_zenoh: the GID in its requests

    def __init__(
        self,
        name: str,
        srv_type: str | ServiceType,
        *,
        node: NodeLike | None = None,
        timeout: float = 10.0,
        announce: bool = True,
    ) -> None:
        super().__init__(node)
        self._wire = self._place_service(EntityKind.SERVICE_CLIENT, name, srv_type, announce)
        self.timeout = timeout
        self._transport = self.context.transport
        session = self._transport.session
        self._get = session.get
        self._matching = Signal()
        #: whether a server matched at the last matching event, how many came, and when the
        #: last server went (a call that ended without a reply looks at them to tell a dropped
        #: link from no server)
        self._matched = False
        self._match_events = 0
        self._unmatched_at = -LINK_SETTLE
        #: calls in flight that Zenoh may never end: what ends each as unavailable
        self._calls: set[Callable[[], None]] = set()
        self._querier = session.declare_querier(self.key)
        self._listener = self._querier.declare_matching_listener(
            lambda status: self._on_matching(bool(status.matching))
        )
        self._keep(self._listener)
        self._keep(self._querier)
        self._announce()

    def service_is_ready(self) -> bool:
        """Whether a server (a zros one, or a ROS one behind a bridge) is reachable now."""
        with self._in_use:  # close() cannot undeclare the querier while it is read
            if self._closed:
                return False
            status = self._querier.matching_status  # a MatchingStatus: the stub says bool
            return bool(status.matching)  # type: ignore[attr-defined]  # see above

    def wait_for_service(
        self, timeout: float | None = 5.0, *, timeout_sec: float | Unset | None = UNSET
    ) -> bool:
        """Wait until a server is reachable; returns whether one showed up in time (False once
        closed, and after Ctrl-C). ``timeout_sec`` is rclpy's spelling of ``timeout``."""
        timeout = either_timeout(timeout, timeout_sec, 5.0)
        self._matching.wait_for(lambda: self._closed or self.service_is_ready(), timeout)
        return not self._closed and self.service_is_ready()

    def _request(self, request: Message | None, fields: dict[str, object]) -> bytes:
        if self._closed:
            raise ServiceError(f'the client of {self.name} was closed')
        problem = self._transport.link_problem()
        if problem is not None and not self.service_is_ready():
            raise LinkLostError(f'cannot call {self.name}: {problem}')
        if request is None:
            request = self.Request(**fields)
        elif fields:
            raise TypeError('give a request or its fields, not both')
        elif type(request) is not self.Request:
            got = getattr(request, '__msgtype__', type(request).__name__)
            raise TypeError(f'{self.name} takes {self.Request.__msgtype__}, not {got}')
        return encode(request)

    def _send(
        self, data: bytes, timeout: float, handler: Callback[Reply] | None, attachment: bytes | None
    ) -> Handler[Reply] | None:
        """Send a request (with what the wire attaches); Zenoh's reply channel (None when
        ``handler`` takes the replies)."""
        replies: Handler[Reply] | None = self._get(
            self.key, handler, payload=data, timeout=timeout, priority=PRIORITY[SERVICE_PRIORITY],
            express=True, **self._wire.query_options(attachment),
        )  # fmt: skip
        return replies

    def _outcome(
        self, reply: Reply, started: float, timeout: float, sent: bytes | None = None
    ) -> Message | ServiceError:
        """The response of a reply, or the error to raise."""
        if reply.ok is not None:
            mismatch = self._wire.reply_problem(reply.ok, sent)
            if mismatch is not None:
                return ServiceCallError(f'{self.name}: {mismatch}')
            data = reply.ok.payload.to_bytes()
            try:
                return decode(self.Response, data)
            except CdrError as exc:
                return ServiceCallError(
                    f'the reply of {self.name} does not decode as '
                    f'{self.Response.__msgtype__}: {exc}'
                )
        if reply.err is None:  # Zenoh gives one of the two
            return ServiceCallError(f'{self.name} replied with neither a response nor an error')
        text = reply.err.payload.to_string()
        if text.startswith(ERROR_PREFIX):
            return ServiceCallError(text[len(ERROR_PREFIX) :])
        if time.monotonic() - started >= timeout * 0.98:  # Zenoh's own "Timeout" reply
            return ServiceTimeoutError(f'{self.name} did not reply within {timeout:g} s')
        return ServiceCallError(f'{self.name} replied with an error: {text}')

    def _link_may_have_dropped(self, matched: bool, events: int) -> bool:
        """Whether a call sent when ``matched`` and ``events`` were the matching state, which
        ended without a reply, may have lost its link: a server was there while it waited, or
        went a moment before it was sent (Zenoh reports the servers behind a dropped link gone
        before it reports the drop)."""
        return (
            matched
            or self._match_events != events
            or time.monotonic() - self._unmatched_at < LINK_SETTLE
        )

    def _no_reply(self, dropped: bool) -> ServiceUnavailableError:
        """The error of a call that ended without a reply: the lost link when it dropped
        (waiting up to LINK_SETTLE to hear of the drop when ``dropped`` says it may have)."""
        if dropped and self._transport.wait_unlinked(LINK_SETTLE):
            problem = self._transport.link_problem()
            if problem is not None:
                return LinkLostError(f'{self.name} got no reply: {problem}')
        return self._unavailable()

    def _unavailable(self) -> ServiceUnavailableError:
        return ServiceUnavailableError(
            f'no server for {self.name} [{self.type_name}] is reachable (key {self.key!r}); '
            'wait_for_service() waits for one'
        )

    def call(
        self,
        request: Message | None = None,
        timeout: float | None = None,
        *,
        timeout_sec: float | Unset | None = UNSET,
        **fields: object,
    ) -> Message:
        """Call the service and return its response (see the class docstring for errors);
        Ctrl-C raises KeyboardInterrupt. ``timeout_sec`` is rclpy's spelling of ``timeout``."""
        data = self._request(request, fields)
        timeout = either_timeout(timeout, timeout_sec, None)
        timeout = self.timeout if timeout is None else timeout
        started = time.monotonic()
        sent = self._wire.request_attachment()
        matched, events = self._matched, self._match_events
        if threading.current_thread() is threading.main_thread():
            # Zenoh's reply channel runs the signal handler, which raises in this block
            with raises_on_interrupt():
                replies = self._send(data, timeout, None, sent)
                reply = next(iter(replies), None) if replies is not None else None
        else:
            reply = self._first_reply(data, timeout, sent)
        if reply is None:
            raise self._no_reply(self._link_may_have_dropped(matched, events))
        outcome = self._outcome(reply, started, timeout, sent)
        if isinstance(outcome, ServiceTimeoutError):
            raise ServiceTimeoutError(f'{outcome}{unanswered_here(self.name, self.key)}')
        if isinstance(outcome, ServiceError):
            raise outcome
        return outcome

    def _first_reply(self, data: bytes, timeout: float, sent: bytes | None) -> Reply | None:
        """The first reply (None if none came) waited for where Ctrl-C can end the wait: a
        Rust channel cannot be interrupted from another thread, a Signal can."""
        first: list[Reply | None] = []
        arrived = Signal()

        def on_reply(reply: Reply | None) -> None:
            if not first:
                first.append(reply)
                arrived.notify()

        # on Zenoh's thread, which only hands the reply over
        handler: Callback[Reply] = Callback(on_reply, lambda: on_reply(None), indirect=False)
        self._send(data, timeout, handler, sent)
        if not arrived.wait_for(lambda: bool(first), None):  # Zenoh ends every query in time
            raise KeyboardInterrupt
        return first[0]

    #: ``client(request)``: a client is callable
    __call__ = call

    def call_async(
        self,
        request: Message | None = None,
        timeout: float | None = None,
        callback: Callable[[ServiceFuture[Message]], object] | None = None,
        **fields: object,
    ) -> ServiceFuture[Message]:
        """Send a request and return at once: a future to ``await`` or ``.result()``.

        ``callback(future)``, if given, runs on the node's spinning thread once it is done.
        """
        data = self._request(request, fields)
        timeout = self.timeout if timeout is None else timeout
        future: ServiceFuture[Message] = ServiceFuture()
        started = time.monotonic()
        executor = self.context.executor
        sent = self._wire.request_attachment()
        matched, events = self._matched, self._match_events

        ended = threading.Lock()

        def on_reply(reply: Reply) -> None:
            if not future.done():
                future.settle(self._outcome(reply, started, timeout, sent))

        def end(error: Callable[[], ServiceError]) -> None:
            if not ended.acquire(False):  # Zenoh's end, or the server went away: once
                return
            self._calls.discard(gone)
            if not future.done():
                future.settle(error())
            if callback is not None:
                executor.call_soon(lambda: callback(future))

        def gone() -> None:
            end(self._gone)

        def no_reply() -> None:  # on Zenoh's thread, which must not wait to hear of the link
            if future.done() or not self._link_may_have_dropped(matched, events):
                end(self._unavailable)
            else:
                waiter = threading.Thread(
                    target=lambda: end(lambda: self._no_reply(True)),
                    name='zros-call-link-check',
                    daemon=True,
                )
                waiter.start()

        self._calls.add(gone)
        try:
            self._send(data, timeout, Callback(on_reply, no_reply), sent)
        except BaseException:
            self._calls.discard(gone)
            raise
        return future

    def _on_matching(self, matching: bool) -> None:
        """The querier's matching status changed (on Zenoh's thread)."""
        if self._matched and not matching:
            self._unmatched_at = time.monotonic()
        self._matched = matching
        self._match_events += 1
        self._matching.notify()
        if not matching and self._calls:
            # a reply cannot be in transit over a link that is down: no grace then
            grace = 0.0 if self._transport.link_problem() is not None else GONE_GRACE
            check = threading.Timer(grace, self._end_calls_if_gone)
            check.daemon = True
            check.start()

    def _end_calls_if_gone(self) -> None:
        """End the calls in flight as unavailable when still no server matches: a query whose
        queryable went away while it was on its way is not always ended by Zenoh (seen under
        load, rmw_zenoh wire), and an action's result waits for 30 days."""
        if self._closed or self.service_is_ready():  # a closed client's calls end as they come
            return
        for gone in list(self._calls):
            gone()

    def _gone(self) -> ServiceUnavailableError:
        problem = self._transport.link_problem()
        if problem is not None:
            return LinkLostError(f'{self.name} got no reply: {problem}')
        return ServiceUnavailableError(
            f'no server for {self.name} [{self.type_name}] answered: the server went away '
            'before it replied'
        )

    def close(self) -> None:
        """Withdraw the client; calls in flight still end (with their reply or error)."""
        super().close()

    def _on_close(self) -> None:
        self._matching.notify()

    def __repr__(self) -> str:
        return f'<zros Client {self.name} [{self.type_name}]>'
