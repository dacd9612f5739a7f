"""Service servers: a queryable (plus its token) whose queries wait for the node to spin.

Payloads are a CDR header and the request or response body (the bridge adds and strips the DDS
request id). A server answers each query exactly once; handlers run on the thread that spins
the node (async handlers on its event loop).
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import inspect
import logging
import threading
import time
import weakref
from collections.abc import Callable, Coroutine
from typing import cast

from zenoh import Query

from zros.cdr import CdrError
from zros.cdr.interfaces import ServiceType
from zros.cdr.message import Message, decode, encode
from zros.keyexpr.kinds import EntityKind
from zros.runtime.defaults import NodeLike
from zros.runtime.executor import Work
from zros.runtime.signal import Signal, interrupted
from zros.services.errors import (
    BRIDGE_TIMEOUT,
    ERROR_PREFIX,
    MAX_PENDING,
    ServiceError,
)
from zros.services.service_entity import ServiceEntity

_log = logging.getLogger('zros')

#: what answers a request: ``handler(request)`` or rclpy's ``handler(request, response)``,
#: returning the response (or a coroutine that does)
ServiceHandler = Callable[[Message], object] | Callable[[Message, Message], object]


def _takes_response(handler: ServiceHandler) -> bool:
    """Whether ``handler`` has rclpy's form ``handler(request, response)``."""
    try:
        parameters = inspect.signature(handler).parameters.values()
    except (TypeError, ValueError):
        return False
    positional = [
        p
        for p in parameters
        if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) and p.default is p.empty
    ]
    return len(positional) >= 2 or any(p.kind is p.VAR_POSITIONAL for p in parameters)


#: the servers of this process, to explain a call that one of them left unanswered
_served: weakref.WeakSet[Service] = weakref.WeakSet()


def unanswered_here(name: str, key: str) -> str:
    """Why a server of this process holds a request to ``name`` unanswered ('' if none does):
    the node serving it is not spinning, or it is the caller's own node, busy with the callback
    that waits for the answer (rclpy deadlocks there too)."""
    caller = threading.get_ident()
    for server in list(_served):
        if server.name == name and server.key == key:
            reason = server.why_unanswered(caller)
            if reason:
                return reason
    return ''


class Service(ServiceEntity):
    """A service server (rosR had none; rclpy: ``node.create_service``).

    With a ``handler`` each request is answered by ``handler(request)`` (or rclpy's
    ``handler(request, response)``), which returns the response; it runs while the node spins,
    and may be ``async``. Without one, poll: ``has_request()``, ``take_request()``, then
    ``respond(response)``.

    A handler that raises or returns something else than a response is logged, and the caller
    gets an error reply: a zros client raises :class:`ServiceCallError` with the reason. A ROS
    client behind the bridge gets nothing (ROS services have no error channel): its call waits
    until its own timeout. So does it when a reply comes later than the bridge waits
    (``queries_timeout``, 5 s by default), which zros logs.

    ``(name, type)`` as :class:`zros.Subscriber` takes them, ``node`` None the default node of
    ``zros.init``; ``node.create_service(type, name)`` takes rclpy's order. Both are on purpose.
    """

    gid: bytes | None  #: rmw_zenoh: the GID in its replies

    def __init__(
        self,
        name: str,
        srv_type: str | ServiceType,
        handler: ServiceHandler | None = None,
        *,
        node: NodeLike | None = None,
        announce: bool = True,
        inline: Callable[[], bool] | None = None,
    ) -> None:
        super().__init__(node)
        wire = self._place_service(EntityKind.SERVICE_SERVER, name, srv_type, announce)
        self._handler: Callable[[Message], object] | None = None
        if handler is not None and _takes_response(handler):
            with_response = cast('Callable[[Message, Message], object]', handler)
            response = self.Response
            self._handler = lambda request: with_response(request, response())
        elif handler is not None:
            self._handler = cast('Callable[[Message], object]', handler)
        #: internal services whose handler runs no user code answer on Zenoh's thread while
        #: this says so (a node's parameters answer even when nobody spins it)
        self._inline = inline
        self._pending: collections.deque[tuple[Query, float]] = collections.deque()
        self._taken: dict[int, tuple[Message, Query, float]] = {}
        self._work = Work(self._dispatch)
        self._arrived = Signal()
        self._warned_late = False
        self._warned_bad = False
        self.received = 0  #: requests received
        self.failed = 0  #: requests answered with an error
        self._requests = wire.requests(self.name, ERROR_PREFIX)
        self._serve(wire, self._on_query)
        self._announce()
        _served.add(self)

    # --- on Zenoh's thread -------------------------------------------------------------------

    def _on_query(self, query: Query) -> None:
        if not self._requests.admit(query):
            self.failed += 1
            return
        if len(self._pending) >= MAX_PENDING:
            self._fail(query, f'{self.name} holds {MAX_PENDING} unanswered requests', None)
            return
        self._pending.append((query, time.monotonic()))
        self.received += 1
        if self._inline is not None and self._inline():
            self._dispatch()
        elif self._handler is not None:
            self.context.executor.schedule(self._work)
        if self._arrived:
            self._arrived.notify()

    # --- answering ---------------------------------------------------------------------------

    def _reply(self, query: Query, response: object, arrived: float) -> None:
        if type(response) is not self.Response:
            got = getattr(response, '__msgtype__', type(response).__name__)
            self._fail(
                query,
                f'the handler of {self.name} returned {got}, not {self.Response.__msgtype__}',
                arrived,
            )
            return
        try:
            data = encode(response)
        except CdrError as exc:
            self._fail(query, f'the response of {self.name} does not encode: {exc}', arrived)
            return
        self._requests.reply(query, data)
        self._check_late(arrived)

    def _fail(self, query: Query, reason: str, arrived: float | None, log: bool = True) -> None:
        self.failed += 1
        if log:
            _log.error('%s', reason)
        self._requests.fail(query, reason)

    def _check_late(self, arrived: float) -> None:
        elapsed = time.monotonic() - arrived
        if elapsed > BRIDGE_TIMEOUT and not self._warned_late:
            self._warned_late = True
            _log.warning(
                'service %s answered after %.1f s: zenoh-bridge-ros2dds waits %g s by default '
                '(queries_timeout), so a ROS client behind it never gets such late replies',
                self.name,
                elapsed,
                BRIDGE_TIMEOUT,
            )

    def _decode(self, query: Query, arrived: float) -> Message | None:
        payload = query.payload
        data = payload.to_bytes() if payload is not None else b''
        try:
            return decode(self.Request, data)
        except CdrError as exc:
            reason = (
                f'a request to {self.name} does not decode as {self.Request.__msgtype__}: {exc}'
            )
            if not self._warned_bad:  # once per service: a broken client may send many
                self._warned_bad = True
                _log.warning('%s (reported once)', reason)
            self._fail(query, reason, arrived, log=False)
            return None

    def _dispatch(self) -> int:
        handler = self._handler
        done = 0
        while self._pending and handler is not None:
            try:
                query, arrived = self._pending.popleft()
            except IndexError:  # taken by another thread (an inline answer)
                break
            request = self._decode(query, arrived)
            if request is None:
                continue
            done += 1
            try:
                result = handler(request)
            except Exception as exc:  # a user handler: logged, the caller gets an error reply
                _log.exception('the handler of service %s raised', self.name)
                self._fail(query, f'the handler of {self.name} raised {exc!r}', arrived, False)
                continue
            if inspect.iscoroutine(result):
                self._await(result, query, arrived)
            else:
                self._reply(query, result, arrived)
        return done

    def _await(
        self, coroutine: Coroutine[object, None, object], query: Query, arrived: float
    ) -> None:
        def finished(future: concurrent.futures.Future[object]) -> None:
            try:
                response = future.result()
            except BaseException as exc:  # CancelledError too: the query must be answered
                if not isinstance(exc, asyncio.CancelledError):
                    _log.error('the handler of service %s raised', self.name, exc_info=exc)
                self._fail(query, f'the handler of {self.name} raised {exc!r}', arrived, False)
                return
            self._reply(query, response, arrived)

        self.context.executor.run_coroutine(coroutine).add_done_callback(finished)

    def why_unanswered(self, caller: int) -> str:
        """Why this server holds a request unanswered, for a call from thread ``caller`` that
        timed out ('' when it holds none, or is polled: the program takes requests itself)."""
        if not self._pending or self._handler is None:
            return ''
        node = self.context.fully_qualified_name
        if self.context.executor.callback_thread == caller:
            return (
                f'; its server is node {node}, and this call waits inside a callback of that '
                'node, so the handler cannot run until the callback returns: use call_async() '
                'and take the response in a done callback, or serve it from a node spun on '
                'another thread (or made with immediate_callbacks=True)'
            )
        return (
            f'; its server, node {node} of this process, holds the request unanswered: nobody '
            'spins that node, or its callbacks are busy (spin it on a thread of its own, or '
            'make it with immediate_callbacks=True)'
        )

    # --- polling (rosR style) ------------------------------------------------------------------

    def has_request(self) -> bool:
        """Whether a request waits to be taken."""
        return bool(self._pending)

    def take_request(self) -> Message | None:
        """The oldest waiting request (None when there is none); answer it with ``respond``."""
        while self._pending:
            query, arrived = self._pending.popleft()
            request = self._decode(query, arrived)
            if request is not None:
                self._taken[id(request)] = (request, query, arrived)
                return request
        return None

    def wait_for_request(self, timeout: float | None = None) -> Message | None:
        """Block until a request comes, then take it (None on timeout, once closed, and after
        Ctrl-C)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            request = self.take_request()
            if request is not None or self._closed:
                return request
            remaining = None if deadline is None else deadline - time.monotonic()
            if interrupted() or (remaining is not None and remaining <= 0):
                return None
            self._arrived.wait(self._has_request_or_closed, remaining, interruptible=True)

    def _has_request_or_closed(self) -> bool:
        return bool(self._pending) or self._closed

    def respond(self, response: Message, request: Message | None = None) -> None:
        """Answer ``request`` (by default the oldest one taken and not answered yet)."""
        if request is None:
            if not self._taken:
                raise ServiceError(f'{self.name}: no request was taken, so none can be answered')
            key = next(iter(self._taken))
        else:
            key = id(request)
            if key not in self._taken:
                raise ServiceError(f'{self.name}: that request was not taken or already answered')
        _, query, arrived = self._taken.pop(key)
        if type(response) is not self.Response:
            got = getattr(response, '__msgtype__', type(response).__name__)
            self._taken[key] = (_, query, arrived)
            raise TypeError(f'{self.name} answers with {self.Response.__msgtype__}, not {got}')
        self._reply(query, response, arrived)

    # --- lifetime ------------------------------------------------------------------------------

    def close(self) -> None:
        """Withdraw the service; waiting and taken requests get an error reply."""
        super().close()

    def _on_close(self) -> None:
        self.context.executor.cancel(self._work)
        while self._pending:
            query, arrived = self._pending.popleft()
            self._fail(query, f'the service {self.name} closed', arrived, log=False)
        for _, query, arrived in self._taken.values():
            self._fail(query, f'the service {self.name} closed', arrived, log=False)
        self._taken.clear()
        self._arrived.notify()

    def __repr__(self) -> str:
        return f'<zros Service {self.name} [{self.type_name}]>'
