"""Services through zenoh-bridge-ros2dds: a server is a queryable, a call is a query.

Payloads are a CDR header and the request or response body (the bridge adds and strips the DDS
request id). A server answers each query exactly once; handlers run on the thread that spins the
node (async handlers on its event loop). A client's ``call`` waits on Zenoh's reply channel
directly, so it works with or without spinning and never deadlocks inside a callback.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import inspect
import logging
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from zros.cdr import CdrError
from zros.cdr.interfaces import ServiceType
from zros.cdr.message import Message, decode, encode
from zros.errors import ZrosError
from zros.keyexpr.kinds import EntityKind
from zros.runtime.futures import ServiceFuture
from zros.runtime.signal import Signal, interrupted, raises_on_interrupt
from zros.wire import Requests, Sequence, attachment_of_reply, entity_wire

if TYPE_CHECKING:
    from zros.node import Node

_log = logging.getLogger('zros')

#: what a zenoh-bridge-ros2dds waits for a reply by default (``queries_timeout.default``)
BRIDGE_TIMEOUT = 5.0
#: requests a server holds before it refuses more (each answered with an error)
MAX_PENDING = 10_000
#: error replies of zros servers start with this, so clients can tell them from Zenoh's own
ERROR_PREFIX = 'zros service error: '


class ServiceError(ZrosError):
    """A service call failed."""


class ServiceUnavailableError(ServiceError):
    """No server answered: none exists for the service (or it went away during the call)."""


class ServiceTimeoutError(ServiceError, TimeoutError):
    """The server did not reply in time."""


class ServiceCallError(ServiceError):
    """The server replied with an error (its handler raised, or the request did not decode),
    or its reply does not decode."""


def _node(node: Node | None) -> Node:
    if node is not None:
        return node
    from zros.api import default_node

    return default_node()


def service_type(node: Node, srv_type: str | ServiceType) -> ServiceType:
    """The service type of a name (``pkg/srv/Name`` or ``pkg/Name``) or a ServiceType."""
    if isinstance(srv_type, ServiceType):
        return srv_type
    found = node.registry.get_type(srv_type)
    if not isinstance(found, ServiceType):
        raise TypeError(f'{srv_type} is not a service type')
    return found


class _ServiceEntity:
    """What servers and clients share: a node, a service name, its key and its tokens."""

    kind: EntityKind

    def __init__(self, node: Node, name: str, srv_type: str | ServiceType, announce: bool) -> None:
        node._check_open()
        self.node = node
        self.srv_type = service_type(node, srv_type)
        self.type_name = self.srv_type.__srvtype__
        self.Request = self.srv_type.Request
        self.Response = self.srv_type.Response
        self.name = node.resolve_name(name, 'service name')
        wire = entity_wire(
            node, self.kind, self.name, self.type_name, self.Request._registry, announce=announce
        )
        self.key = wire.key
        self._tokens: tuple[str, ...] = wire.tokens
        self.gid = wire.gid  #: rmw_zenoh: the GID in its attachments
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


def _takes_response(handler: Callable[..., Any]) -> bool:
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


class Service(_ServiceEntity):
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
    """

    kind = EntityKind.SERVICE_SERVER

    def __init__(
        self,
        name: str,
        srv_type: str | ServiceType,
        handler: Callable[..., Any] | None = None,
        *,
        node: Node | None = None,
        announce: bool = True,
        inline: Callable[[], bool] | None = None,
    ) -> None:
        owner = _node(node)
        super().__init__(owner, name, srv_type, announce)
        self._handler = handler
        #: internal services whose handler runs no user code answer on Zenoh's thread while
        #: this says so (a node's parameters answer even when nobody spins it)
        self._inline = inline
        self._with_response = handler is not None and _takes_response(handler)
        self._pending: collections.deque[tuple[Any, float]] = collections.deque()
        self._taken: dict[int, tuple[Message, Any, float]] = {}
        self._scheduled = False
        self._arrived = Signal()
        self._warned_late = False
        self._warned_bad = False
        self.received = 0  #: requests received
        self.failed = 0  #: requests answered with an error
        self._requests = Requests(self.gid is not None, self.name, ERROR_PREFIX)
        self._queryable = owner.transport.session.declare_queryable(
            self.key, self._on_query, complete=True
        )
        self._announce()
        owner._add(self)

    # --- on Zenoh's thread -------------------------------------------------------------------

    def _on_query(self, query: Any) -> None:
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
            self.node._executor.schedule(self)
        if self._arrived:
            self._arrived.notify()

    # --- answering ---------------------------------------------------------------------------

    def _reply(self, query: Any, response: Message, arrived: float) -> None:
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

    def _fail(self, query: Any, reason: str, arrived: float | None, log: bool = True) -> None:
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

    def _decode(self, query: Any, arrived: float) -> Message | None:
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
                if self._with_response:
                    result = handler(request, self.Response())
                else:
                    result = handler(request)
            except Exception as exc:
                _log.exception('the handler of service %s raised', self.name)
                self._fail(query, f'the handler of {self.name} raised {exc!r}', arrived, False)
                continue
            if inspect.iscoroutine(result):
                self._await(result, query, arrived)
            else:
                self._reply(query, result, arrived)
        return done

    def _await(self, coroutine: Any, query: Any, arrived: float) -> None:
        def finished(future: concurrent.futures.Future[Any]) -> None:
            try:
                response = future.result()
            except BaseException as exc:  # CancelledError too: the query must be answered
                if not isinstance(exc, asyncio.CancelledError):
                    _log.error('the handler of service %s raised', self.name, exc_info=exc)
                self._fail(query, f'the handler of {self.name} raised {exc!r}', arrived, False)
                return
            self._reply(query, response, arrived)

        self.node.run_coroutine(coroutine).add_done_callback(finished)

    # --- polling (rosR style) ------------------------------------------------------------------

    def has_request(self) -> bool:
        """Whether a request waits to be taken."""
        return bool(self._pending)

    def take_request(self) -> Any:
        """The oldest waiting request (None when there is none); answer it with ``respond``."""
        while self._pending:
            query, arrived = self._pending.popleft()
            request = self._decode(query, arrived)
            if request is not None:
                self._taken[id(request)] = (request, query, arrived)
                return request
        return None

    def wait_for_request(self, timeout: float | None = None) -> Any:
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
        if self._closed:
            return
        self._closed = True
        self._withdraw()
        if not self.node.transport.closed:
            self._queryable.undeclare()
        while self._pending:
            query, arrived = self._pending.popleft()
            self._fail(query, f'the service {self.name} closed', arrived, log=False)
        for _, query, arrived in self._taken.values():
            self._fail(query, f'the service {self.name} closed', arrived, log=False)
        self._taken.clear()
        self.node._remove(self)
        self._arrived.notify()

    def __repr__(self) -> str:
        return f'<zros Service {self.name} [{self.type_name}]>'


class Client(_ServiceEntity):
    """A service client (rclpy: ``node.create_client``).

    ``call(request)`` (or ``call(a=1, b=2)``) returns the response or raises
    :class:`ServiceUnavailableError` (no server), :class:`ServiceTimeoutError` or
    :class:`ServiceCallError` (the server failed). ``call_async`` returns a future to ``await``.
    """

    kind = EntityKind.SERVICE_CLIENT

    def __init__(
        self,
        name: str,
        srv_type: str | ServiceType,
        *,
        node: Node | None = None,
        timeout: float = 10.0,
        announce: bool = True,
    ) -> None:
        import zenoh

        owner = _node(node)
        super().__init__(owner, name, srv_type, announce)
        self.timeout = timeout
        self._zenoh = zenoh
        session = owner.transport.session
        self._get = session.get
        #: rmw_zenoh: every request carries an attachment and asks every complete queryable
        self._sequence = Sequence(self.gid) if self.gid is not None else None
        self._options: dict[str, Any] = {}
        if self._sequence is not None:
            self._options = {
                'target': zenoh.QueryTarget.ALL_COMPLETE,
                'consolidation': zenoh.ConsolidationMode.NONE,
            }
        self._matching = Signal()
        self._querier = session.declare_querier(self.key)
        self._listener = self._querier.declare_matching_listener(
            lambda _status: self._matching.notify()
        )
        self._announce()
        owner._add(self)

    def service_is_ready(self) -> bool:
        """Whether a server (a zros one, or a ROS one behind a bridge) is reachable now."""
        return bool(self._querier.matching_status.matching)

    def wait_for_service(self, timeout: float | None = 5.0) -> bool:
        """Wait until a server is reachable; returns whether one showed up in time (False once
        closed, and after Ctrl-C)."""
        self._matching.wait_for(lambda: self._closed or self.service_is_ready(), timeout)
        return not self._closed and self.service_is_ready()

    def _request(self, request: Message | None, fields: dict[str, Any]) -> bytes:
        if self._closed:
            raise ServiceError(f'the client of {self.name} was closed')
        if request is None:
            request = self.Request(**fields)
        elif fields:
            raise TypeError('give a request or its fields, not both')
        elif type(request) is not self.Request:
            got = getattr(request, '__msgtype__', type(request).__name__)
            raise TypeError(f'{self.name} takes {self.Request.__msgtype__}, not {got}')
        return encode(request)

    def _send(self, data: bytes, timeout: float, handler: Any, attachment: bytes | None) -> Any:
        """Send a request (with its rmw_zenoh attachment); Zenoh's reply channel."""
        if attachment is None:
            return self._get(self.key, handler, payload=data, timeout=timeout)
        return self._get(
            self.key, handler, payload=data, timeout=timeout, attachment=attachment,
            **self._options,
        )  # fmt: skip

    def _outcome(
        self, reply: Any, started: float, timeout: float, sent: bytes | None = None
    ) -> Any:
        """The response of a reply, or the error to raise."""
        if reply.ok is not None:
            if sent is not None:
                mismatch = attachment_of_reply(reply.ok, sent)
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
        text = reply.err.payload.to_string()
        if text.startswith(ERROR_PREFIX):
            return ServiceCallError(text[len(ERROR_PREFIX) :])
        if time.monotonic() - started >= timeout * 0.98:  # Zenoh's own "Timeout" reply
            return ServiceTimeoutError(f'{self.name} did not reply within {timeout:g} s')
        return ServiceCallError(f'{self.name} replied with an error: {text}')

    def _unavailable(self) -> ServiceUnavailableError:
        return ServiceUnavailableError(
            f'no server for {self.name} [{self.type_name}] is reachable (key {self.key!r}); '
            'wait_for_service() waits for one'
        )

    def call(
        self, request: Message | None = None, timeout: float | None = None, **fields: Any
    ) -> Any:
        """Call the service and return its response (see the class docstring for errors);
        Ctrl-C raises KeyboardInterrupt."""
        data = self._request(request, fields)
        timeout = self.timeout if timeout is None else timeout
        started = time.monotonic()
        sent = None if self._sequence is None else self._sequence.next()
        if threading.current_thread() is threading.main_thread():
            # Zenoh's reply channel runs the signal handler, which raises in this block
            with raises_on_interrupt():
                reply = next(iter(self._send(data, timeout, None, sent)), None)
        else:
            reply = self._first_reply(data, timeout, sent)
        if reply is None:
            raise self._unavailable()
        outcome = self._outcome(reply, started, timeout, sent)
        if isinstance(outcome, ServiceError):
            raise outcome
        return outcome

    def _first_reply(self, data: bytes, timeout: float, sent: bytes | None) -> Any:
        """The first reply (None if none came) waited for where Ctrl-C can end the wait: a
        Rust channel cannot be interrupted from another thread, a Signal can."""
        first: list[Any] = []
        arrived = Signal()

        def on_reply(reply: Any) -> None:
            if not first:
                first.append(reply)
                arrived.notify()

        # on Zenoh's thread, which only hands the reply over
        handler = self._zenoh.handlers.Callback(on_reply, lambda: on_reply(None), indirect=False)
        self._send(data, timeout, handler, sent)
        if not arrived.wait_for(lambda: bool(first), None):  # Zenoh ends every query in time
            raise KeyboardInterrupt
        return first[0]

    __call__ = call

    def call_async(
        self,
        request: Message | None = None,
        timeout: float | None = None,
        callback: Callable[[Any], object] | None = None,
        **fields: Any,
    ) -> ServiceFuture:
        """Send a request and return at once: a future to ``await`` or ``.result()``.

        ``callback(future)``, if given, runs on the node's spinning thread once it is done.
        """
        data = self._request(request, fields)
        timeout = self.timeout if timeout is None else timeout
        future = ServiceFuture()
        started = time.monotonic()
        executor = self.node._executor
        sent = None if self._sequence is None else self._sequence.next()

        def on_reply(reply: Any) -> None:
            if not future.done():
                future.settle(self._outcome(reply, started, timeout, sent))

        def on_end() -> None:
            if not future.done():
                future.settle(self._unavailable())
            if callback is not None:
                executor.call_soon(lambda: callback(future))

        handler = self._zenoh.handlers.Callback(on_reply, on_end)
        self._send(data, timeout, handler, sent)
        return future

    def close(self) -> None:
        """Withdraw the client; calls in flight still end (with their reply or error)."""
        if self._closed:
            return
        self._closed = True
        self._withdraw()
        if not self.node.transport.closed:
            self._listener.undeclare()
            self._querier.undeclare()
        self.node._remove(self)
        self._matching.notify()

    def __repr__(self) -> str:
        return f'<zros Client {self.name} [{self.type_name}]>'
