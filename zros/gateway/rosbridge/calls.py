"""Services and actions for rosbridge clients.

* ``call_service``: rosapi's services are answered by
  :class:`~zros.gateway.rosbridge.rosapi.Rosapi`; any other goes through a zros service client
  (the type is the graph's), without blocking the client's other requests. The answer is a
  ``service_response`` (``result: false`` with the reason when the call failed).
* ``advertise_service``: a client serves a ROS service. The gateway declares a zros service;
  each request goes to the client as a ``call_service`` with an id, and its
  ``service_response`` answers the ROS caller (``result: false`` gives the caller an error).
  A service another node of the graph serves is refused (unless ``allow_override``): the
  callers of a robot's service must not be answered by a web page.
* ``send_action_goal``: a goal through a zros action client, with ``action_feedback``
  messages when asked and one ``action_result``; ``cancel_action_goal`` cancels it.
* ``advertise_action`` and its ops: a client serves an action
  (:mod:`~zros.gateway.rosbridge.served_actions`, reached as :attr:`Calls.served`).
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import functools
import itertools
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar

from zros.errors import ZrosError
from zros.gateway.common.counts import count_down
from zros.gateway.common.entities import ClientCache
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.common.json_types import text_field
from zros.gateway.common.views import offered_services, owners
from zros.gateway.rosbridge.conversion import ConversionError, Values
from zros.gateway.rosbridge.rosapi import Rosapi
from zros.gateway.rosbridge.served_actions import MAX_SERVED, ServedActions
from zros.keyexpr.kinds import EntityKind

if TYPE_CHECKING:
    from collections.abc import Awaitable

    from zros.actions import ActionClient, ClientGoalHandle
    from zros.cdr import JsonValue, Message
    from zros.gateway.common.json_types import JsonObject
    from zros.gateway.rosbridge.topics import Peer
    from zros.graph import Endpoint
    from zros.node import Node
    from zros.services import Client, Service

_log = logging.getLogger('zros.gateway')
_T = TypeVar('_T')

#: service calls and action goals one client may have waiting for their answer at once
MAX_PENDING = 1000
#: seconds a service call may take unless the client says (``timeout``)
SERVICE_TIMEOUT = 10.0
#: seconds a client serving a service has to answer a request
RESPONSE_TIMEOUT = 10.0
#: seconds a result waits for the feedback received before it to be sent
FEEDBACK_WAIT = 2.0
#: rosbridge's status of a goal that failed before reaching the server (GoalStatus UNKNOWN)
STATUS_UNKNOWN = 0


@dataclass
class _Offered:
    """A service a client serves."""

    peer: Peer
    name: str
    response: type[Message]
    service: Service | None = None
    pending: dict[str, concurrent.futures.Future[Message]] = field(default_factory=dict)


class Calls:
    """Service calls, client-served services and action goals of one gateway's clients.
    ``allow_override``: clients may serve services and actions other nodes serve."""

    def __init__(
        self,
        node: Node,
        values: Values,
        allowed: NameFilter,
        rosapi: Rosapi,
        workers: int = 4,
        *,
        allow_override: bool = False,
    ) -> None:
        self._node = node
        self._values = values
        self._allowed = allowed
        self.allow_override = allow_override
        self.rosapi = rosapi
        self._clients: ClientCache[Client] = ClientCache()
        self._actions: ClientCache[ActionClient] = ClientCache()
        self._lock = threading.Lock()
        self._offered: dict[str, _Offered] = {}
        self._goals: dict[tuple[int, JsonValue], _Goal] = {}  # by (peer, id)
        self._pending: collections.Counter[int] = collections.Counter()  # calls and goals
        self._ids = itertools.count(1)
        self._pool = concurrent.futures.ThreadPoolExecutor(workers, 'zros rosbridge calls')
        #: the actions clients serve
        self.served = ServedActions(node, values, self._name, self._request, self.check_unserved)

    def _name(self, name: JsonValue, what: str = 'service') -> str:
        if not isinstance(name, str):
            raise GatewayError(f'the {what} name must be a string, not {name!r}')
        try:
            resolved = self._node.resolve_name(name.partition('#')[0], f'{what} name')
        except (ZrosError, ValueError) as exc:
            raise GatewayError(f'{name!r} is not a valid {what} name: {exc}') from None
        if not (self._allowed(resolved) or self.rosapi.handles(resolved)):
            raise GatewayError(f'{resolved} is not allowed here (services glob)')
        return resolved

    def _request(self, cls: type[Message], args: JsonValue) -> Message:
        if isinstance(args, list):  # rosbridge takes the fields in order too
            args = dict(zip((f for f in cls.get_fields_and_field_types()), args, strict=False))
        try:
            return self._values.from_json(cls, args if args is not None else {})
        except ConversionError as exc:
            raise GatewayError(str(exc)) from None

    def reads(self, op: JsonObject) -> bool:
        """Whether ``op`` only reads: a ``call_service`` of one of rosapi's reads."""
        if op.get('op') != 'call_service':
            return False
        try:
            name = self._name(text_field(op, 'service'))
        except GatewayError:
            return False
        return self.rosapi.handles(name) and not self.rosapi.writes(name)

    def refuse(self, peer: Peer, op: JsonObject, reason: str) -> None:
        """Answer a refused ``call_service`` or ``send_action_goal`` as failed, so that the
        client's caller does not wait for good (other ops have no answer)."""
        if op.get('op') == 'call_service':
            _Answer(peer, op, str(text_field(op, 'service'))).fail(reason)
        elif op.get('op') == 'send_action_goal':
            _Answer(peer, op, str(text_field(op, 'action')), 'action').fail(reason, STATUS_UNKNOWN)

    def _begin(self, peer: Peer, answer: _Answer, status: int | None = None) -> bool:
        """Count a call or goal of ``peer`` waiting for its answer; past :data:`MAX_PENDING`
        it fails at once instead."""
        with self._lock:
            if self._pending[peer.id] < MAX_PENDING:
                self._pending[peer.id] += 1
                return True
        answer.fail(f'a client may have at most {MAX_PENDING} calls and goals waiting', status)
        return False

    def _end(self, peer: Peer) -> None:
        """A call or goal of ``peer`` got its answer."""
        with self._lock:
            count_down(self._pending, peer.id)

    def _served(self, name: str, kind: EntityKind) -> list[Endpoint]:
        """The endpoints of the graph serving ``name`` as a service, or as an action (its
        ``send_goal`` service where the wire shows only that)."""
        node = self._node
        namespace = node.scheme.namespace
        wanted = (
            {name} if kind is EntityKind.SERVICE_SERVER else {name, f'{name}/_action/send_goal'}
        )
        kinds = (kind, EntityKind.SERVICE_SERVER)
        return [e for e in node.graph.endpoints(kinds) if e.ros_name(namespace) in wanted]

    def check_unserved(self, name: str, kind: EntityKind = EntityKind.SERVICE_SERVER) -> None:
        """Refuse to serve ``name`` when another node serves it (unless overriding is
        allowed): GatewayError names the nodes."""
        if self.allow_override:
            return
        node = self._node
        own = node.fully_qualified_name
        found = [e for e in self._served(name, kind) if e.node != own]
        if found:
            what = 'service' if kind is EntityKind.SERVICE_SERVER else 'action'
            raise GatewayError(
                f'{name} is served by {", ".join(owners(found, node.graph))}: a client may not '
                f'take over a {what} of the graph (--allow-service-override allows it)'
            )

    # --- calling -----------------------------------------------------------------------------

    def call_service(self, peer: Peer, op: JsonObject) -> None:
        """A ``call_service`` message; the answer comes later as a ``service_response``."""
        service = text_field(op, 'service')
        name = self._name(service)
        answer = _Answer(peer, op, service)
        if self.rosapi.handles(name):
            args = op.get('args') or {}
            if not isinstance(args, dict):
                raise GatewayError(f'the args of {name} must be an object')
            if not self._begin(peer, answer):
                return
            future = self._pool.submit(self.rosapi.call, name, args)
            future.add_done_callback(lambda f: self._answered(peer, answer, f, lambda v: v))
            return
        type_name = offered_services(self._node, include_hidden=True).get(name)
        if type_name is None:
            answer.fail(f'Service {name} does not exist')
            return
        client: Client = self._clients.get(
            (name, type_name), lambda: self._node.create_client(type_name, name, SERVICE_TIMEOUT)
        )
        try:
            request = self._request(client.Request, op.get('args'))
        except GatewayError as exc:  # rosbridge answers a request it cannot make
            answer.fail(str(exc))
            return
        timeout = op.get('timeout')
        if not isinstance(timeout, (int, float)) or isinstance(timeout, bool) or timeout <= 0:
            timeout = SERVICE_TIMEOUT
        if not self._begin(peer, answer):
            return
        call = client.call_async(request, float(timeout))
        call.add_done_callback(lambda f: self._answered(peer, answer, f, self._values.to_json))

    def _action_client(
        self, name: str, type_name: str
    ) -> tuple[ActionClient, Callable[[bool], None] | None]:
        """The action client for a goal, and what to call when the goal ends (with whether a
        server answered it): the cached client of an action the graph shows, else (not seen
        yet, or invented) one for this goal, kept when the goal ends if a server answered or
        the graph shows the action by then (its routes are up for the next goals), else
        closed, so made-up names leave nothing behind."""
        key = (name, type_name)
        make = functools.partial(self._node.create_action_client, type_name, name)
        if self._served(name, EntityKind.ACTION_SERVER):
            return self._actions.get(key, make), None
        client = make()

        def release(answered: bool) -> None:
            real = answered or self._served(name, EntityKind.ACTION_SERVER)
            if not (real and self._actions.keep(key, client)):
                client.close()

        return client, release

    def _answered(
        self,
        peer: Peer,
        answer: _Answer,
        future: concurrent.futures.Future[_T],
        convert: Callable[[_T], object],
    ) -> None:
        self._end(peer)
        answer.done(future, convert)

    # --- serving -----------------------------------------------------------------------------

    def advertise_service(self, peer: Peer, op: JsonObject) -> None:
        """An ``advertise_service`` message: serve ``service`` by asking the client."""
        name = self._name(text_field(op, 'service'))
        type_text = text_field(op, 'type')
        try:
            service_type = self._node.registry.get_service(type_text)
        except ZrosError as exc:
            raise GatewayError(f'unknown service type {type_text}: {exc}') from None
        with self._lock:
            ours = name in self._offered  # the graph shows it served by the gateway: replaced
            again = ours and self._offered[name].peer is peer
            served = sum(o.peer is peer for o in self._offered.values())
        if not again and served >= MAX_SERVED:
            raise GatewayError(
                f'a client may serve at most {MAX_SERVED} services at once: unadvertise one first'
            )
        if not ours:
            self.check_unserved(name)
        self._withdraw(name, None)  # a service advertised again replaces the older one
        offered = _Offered(peer, name, service_type.Response)
        offered.service = self._node.create_service(service_type, name, self._forward(offered))
        with self._lock:
            self._offered[name] = offered
        _log.info('client %d serves %s [%s]', peer.id, name, service_type.__srvtype__)

    def _forward(self, offered: _Offered) -> Callable[[Message], Awaitable[Message]]:
        async def handle(request: Message) -> Message:
            request_id = f'service_request:{offered.name}:{next(self._ids)}'
            future: concurrent.futures.Future[Message] = concurrent.futures.Future()
            offered.pending[request_id] = future
            try:
                offered.peer.send(
                    {
                        'op': 'call_service',
                        'id': request_id,
                        'service': offered.name,
                        'args': self._values.to_json(request),
                    }
                )
                return await asyncio.wait_for(asyncio.wrap_future(future), RESPONSE_TIMEOUT)
            finally:
                offered.pending.pop(request_id, None)

        return handle

    def service_response(self, peer: Peer, op: JsonObject) -> None:
        """A ``service_response`` message: the answer to a request the gateway forwarded."""
        name = self._name(text_field(op, 'service'))
        with self._lock:
            offered = self._offered.get(name)
        if offered is None or offered.peer is not peer:
            raise GatewayError(f'Service {name} has not been advertised via rosbridge.')
        future = offered.pending.get(op.get('id'))  # type: ignore[arg-type]  # a JSON id: a str key, else no future
        if future is None:
            raise GatewayError(f'Received service response for unrecognized id: {op.get("id")}')
        if op.get('result') is False:
            future.set_exception(
                GatewayError(f'the client serving {name} failed: {op.get("values")}')
            )
            return
        try:
            future.set_result(self._request(offered.response, op.get('values')))
        except GatewayError as exc:
            future.set_exception(exc)
            raise

    def unadvertise_service(self, peer: Peer, op: JsonObject) -> None:
        """An ``unadvertise_service`` message."""
        name = self._name(text_field(op, 'service'))
        if not self._withdraw(name, peer):
            raise GatewayError(
                f"Service {name} has not been advertised via rosbridge, can't unadvertise."
            )

    def _withdraw(self, name: str, peer: Peer | None) -> bool:
        with self._lock:
            offered = self._offered.get(name)
            if offered is None or (peer is not None and offered.peer is not peer):
                return False
            del self._offered[name]
        for future in list(offered.pending.values()):
            if not future.done():
                future.set_exception(GatewayError(f'service {name} was unadvertised'))
        if offered.service is not None:
            offered.service.close()
        return True

    # --- actions -----------------------------------------------------------------------------

    def send_action_goal(self, peer: Peer, op: JsonObject) -> None:
        """A ``send_action_goal`` message: feedback (when asked) and the result follow."""
        action = text_field(op, 'action')
        name = self._name(action, 'action')
        type_text = text_field(op, 'action_type')
        answer = _Answer(peer, op, action, 'action')
        try:
            action_type = self._node.registry.get_action(type_text)
        except (ZrosError, TypeError) as exc:
            raise GatewayError(f'cannot reach action {name} as {type_text}: {exc}') from None
        goal_id = op.get('id')
        try:
            goal = self._request(action_type.Goal, op.get('args'))
        except GatewayError as exc:
            answer.fail(str(exc), STATUS_UNKNOWN)
            return
        if not self._begin(peer, answer, STATUS_UNKNOWN):
            return
        try:
            client, release = self._action_client(name, type_text)
        except (ZrosError, ValueError) as exc:
            self._end(peer)
            raise GatewayError(f'cannot reach action {name} as {type_text}: {exc}') from None

        sent = _Count()
        record = _Goal()
        with self._lock:
            self._goals[peer.id, goal_id] = record

        def on_feedback(feedback: Message) -> None:
            message: dict[str, object] = {
                'op': 'action_feedback',
                'action': action,
                'values': self._values.to_json(feedback),
            }
            if goal_id is not None:
                message['id'] = goal_id
            peer.send(message, answer.compression, answer.fragment_size)
            sent.add()

        def on_answer(future: concurrent.futures.Future[ClientGoalHandle]) -> None:
            try:
                handle = future.result()
            except Exception as exc:  # no server, or it failed: the client is told why
                with self._lock:
                    self._goals.pop((peer.id, goal_id), None)
                self._end(peer)
                if release is not None:
                    self._pool.submit(release, False)
                answer.fail(str(exc), STATUS_UNKNOWN)
                return
            with self._lock:
                record.handle = handle
                cancel = record.cancel
            if cancel:  # asked for before the server accepted the goal
                self._pool.submit(handle.cancel)

            def send_result(result: concurrent.futures.Future[Message]) -> None:
                if feedback is not None:  # the feedback received before the result goes first
                    sent.wait_for(handle.feedback_count, FEEDBACK_WAIT)
                with self._lock:
                    self._goals.pop((peer.id, goal_id), None)
                self._end(peer)
                if release is not None:
                    release(True)  # on the pool's thread, not the goal's
                answer.done(result, self._values.to_json, int(handle.status))

            handle.result_async().add_done_callback(lambda f: self._pool.submit(send_result, f))

        feedback = on_feedback if op.get('feedback') else None
        try:
            sending = client.send_goal_async(goal, feedback)
        except BaseException:
            with self._lock:
                self._goals.pop((peer.id, goal_id), None)
            self._end(peer)
            if release is not None:
                release(False)
            raise
        sending.add_done_callback(on_answer)

    def cancel_action_goal(self, peer: Peer, op: JsonObject) -> None:
        """A ``cancel_action_goal`` message (asked of the server on a thread of the pool)."""
        self._name(text_field(op, 'action'), 'action')
        with self._lock:
            record = self._goals.get((peer.id, op.get('id')))
            if record is None:
                raise GatewayError(f'no goal {op.get("id")!r} of this client is running')
            handle, record.cancel = record.handle, True
        if handle is not None:
            self._pool.submit(handle.cancel)

    # --- lifetime ----------------------------------------------------------------------------

    def drop(self, peer: Peer) -> None:
        """A client left: withdraw the services and actions it served (the goals it sent keep
        running)."""
        with self._lock:
            names = [n for n, o in self._offered.items() if o.peer is peer]
            self._goals = {k: v for k, v in self._goals.items() if k[0] != peer.id}
        for name in names:
            self._withdraw(name, peer)
        self.served.drop(peer)

    def close(self) -> None:
        """Withdraw everything and stop the pool."""
        with self._lock:
            names = list(self._offered)
        for name in names:
            self._withdraw(name, None)
        self.served.close()
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._clients.close()
        self._actions.close()
        self.rosapi.close()


@dataclass
class _Goal:
    """A goal a client sent: its handle once the server accepted it."""

    handle: ClientGoalHandle | None = None
    cancel: bool = False  #: the client asked to cancel it


class _Count:
    """A counter one can wait on."""

    def __init__(self) -> None:
        self._value = 0
        self._changed = threading.Condition()

    def add(self) -> None:
        with self._changed:
            self._value += 1
            self._changed.notify_all()

    def wait_for(self, value: int, timeout: float) -> bool:
        with self._changed:
            return self._changed.wait_for(lambda: self._value >= value, timeout)


class _Answer:
    """Sends the one ``service_response`` or ``action_result`` of a request."""

    def __init__(self, peer: Peer, op: JsonObject, name: str, kind: str = 'service') -> None:
        self.peer = peer
        self.id = op.get('id')
        self.name = name
        self.kind = kind
        compression = op.get('compression')
        self.compression = compression if compression in ('none', 'png') else 'none'
        size = op.get('fragment_size')
        self.fragment_size = size if isinstance(size, int) and size > 0 else 0

    def _send(self, values: object, result: bool, status: int | None) -> None:
        if self.kind == 'service':
            message: dict[str, object] = {'op': 'service_response', 'service': self.name}
        else:
            message = {'op': 'action_result', 'action': self.name, 'status': status}
        message.update(values=values, result=result)
        if self.id is not None:
            message['id'] = self.id
        self.peer.send(message, self.compression, self.fragment_size)

    def fail(self, reason: str, status: int | None = None) -> None:
        """Tell the client the request failed, and why."""
        self._send(reason, False, status)

    def done(
        self,
        future: concurrent.futures.Future[_T],
        convert: Callable[[_T], object],
        status: int | None = None,
    ) -> None:
        """Send the outcome of ``future`` (its result converted, or its error)."""
        try:
            values = convert(future.result())
        except Exception as exc:  # the reason goes to the client, whatever failed
            _log.debug('%s %s failed', self.kind, self.name, exc_info=True)
            self.fail(str(exc) or type(exc).__name__, STATUS_UNKNOWN if status is None else status)
            return
        self._send(values, True, status)
