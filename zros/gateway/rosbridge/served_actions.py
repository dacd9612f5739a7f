"""Actions served by rosbridge clients (rosbridge_suite's ROS 2 ops).

* ``advertise_action`` {action, type}: the gateway declares a zros action server; each goal
  the graph sends goes to the client as a ``send_action_goal`` {id, action, action_type, args,
  feedback: true}, and a ROS client's cancel as a ``cancel_action_goal`` {id, action}.
* ``action_feedback`` {id, action, values}: published as the goal's feedback.
* ``action_result`` {id, action, values, status, result}: ends the goal (status 4 succeeded,
  5 canceled after a cancel request, 6 aborted; ``result: false`` aborts it).
* ``unadvertise_action`` {action}: withdraws the server; running goals are aborted, as they
  are when the client leaves.

A goal's execute callback is a coroutine on the node's event loop awaiting the client's
answer, so a waiting goal holds no thread. Whatever a client sends that does not fit (an id
it was not given, a name it does not serve, values of the wrong shape) is refused with a
status; a result that does not fit still ends the goal, as aborted, so no ROS caller waits
for good.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import itertools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeAlias

from zros.actions import ActionError, GoalStatus
from zros.errors import ZrosError
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.json_types import text_field
from zros.keyexpr.kinds import EntityKind

if TYPE_CHECKING:
    from collections.abc import Awaitable

    from zros.actions import ActionServer, ServerGoalHandle
    from zros.cdr import JsonValue, Message
    from zros.gateway.common.json_types import JsonObject
    from zros.gateway.rosbridge.conversion import Values
    from zros.gateway.rosbridge.topics import Peer
    from zros.node import Node

_log = logging.getLogger('zros.gateway')

#: goals one advertised action may have waiting for its client (later ones are aborted)
MAX_GOALS = 1000
#: services one client may serve at once, and actions (each a Zenoh queryable or several, with
#: threads of their own, and a name in the whole graph)
MAX_SERVED = 100
#: seconds a withdrawn action waits for its aborted goals to report their results
WITHDRAW_WAIT = 5.0
#: the ends a client may give a goal (``status`` of ``action_result``)
ENDS = (GoalStatus.SUCCEEDED, GoalStatus.CANCELED, GoalStatus.ABORTED)

#: the answer a goal waits for: how it ends and its Result, or None when it was withdrawn
_Outcome: TypeAlias = 'tuple[GoalStatus, Message] | None'


@dataclass
class _Running:
    """A goal forwarded to the client, waiting for its ``action_result``."""

    handle: ServerGoalHandle
    answer: concurrent.futures.Future[_Outcome] = field(default_factory=concurrent.futures.Future)
    cancel_sent: bool = False


@dataclass
class _Advertised:
    """An action a client serves."""

    peer: Peer
    name: str  #: resolved
    text: str  #: as the client named it (its messages carry this name)
    type_text: str
    server: ActionServer | None = None
    goals: dict[str, _Running] = field(default_factory=dict)  #: by rosbridge id
    withdrawn: bool = False


class ServedActions:
    """The actions rosbridge clients serve. ``resolve(name, what)`` checks and resolves a
    name; ``convert(cls, values)`` makes a message of JSON values; ``unserved(name, kind)``
    refuses a name another node serves (all raise GatewayError)."""

    def __init__(
        self,
        node: Node,
        values: Values,
        resolve: Callable[[JsonValue, str], str],
        convert: Callable[[type[Message], JsonValue], Message],
        unserved: Callable[[str, EntityKind], None],
    ) -> None:
        self._node = node
        self._values = values
        self._resolve = resolve
        self._convert = convert
        self._unserved = unserved
        self._lock = threading.Lock()
        self._advertised: dict[str, _Advertised] = {}
        self._ids = itertools.count(1)

    # --- advertising -------------------------------------------------------------------------

    def advertise_action(self, peer: Peer, op: JsonObject) -> None:
        """An ``advertise_action`` message: serve ``action`` by asking the client."""
        text = text_field(op, 'action')
        name = self._resolve(text, 'action')
        type_text = text_field(op, 'type')
        try:
            action_type = self._node.registry.get_action(type_text)
        except (ZrosError, TypeError) as exc:
            raise GatewayError(f'unknown action type {type_text}: {exc}') from None
        with self._lock:
            held = self._advertised.get(name)
            if held is not None and held.peer is not peer:
                raise GatewayError(f'Action {name} is already advertised by another client')
            served = sum(a.peer is peer for a in self._advertised.values())
        if held is None and served >= MAX_SERVED:
            raise GatewayError(
                f'a client may serve at most {MAX_SERVED} actions at once: unadvertise one first'
            )
        if held is None:
            self._unserved(name, EntityKind.ACTION_SERVER)
        self._withdraw(name, peer)  # advertised again by the same client: the new one replaces
        advertised = _Advertised(peer, name, text, type_text)
        with self._lock:
            if name in self._advertised:  # another client was quicker
                raise GatewayError(f'Action {name} is already advertised by another client')
            self._advertised[name] = advertised
        try:
            advertised.server = self._node.create_action_server(
                action_type,
                name,
                self._execute(advertised),
                cancel_callback=self._cancel(advertised),
            )
        except (ZrosError, ValueError) as exc:
            with self._lock:
                self._advertised.pop(name, None)
            raise GatewayError(f'cannot serve action {name}: {exc}') from None
        with self._lock:
            gone = advertised.withdrawn  # the gateway closed meanwhile
        if gone:
            advertised.server.close()
            return
        _log.info('client %d serves action %s [%s]', peer.id, name, action_type.__actiontype__)

    def unadvertise_action(self, peer: Peer, op: JsonObject) -> None:
        """An ``unadvertise_action`` message: running goals are aborted."""
        name = self._resolve(text_field(op, 'action'), 'action')
        if not self._withdraw(name, peer):
            raise GatewayError(
                f"Action {name} has not been advertised via rosbridge, can't unadvertise."
            )

    def _withdraw(self, name: str, peer: Peer | None) -> bool:
        with self._lock:
            advertised = self._advertised.get(name)
            if advertised is None or (peer is not None and advertised.peer is not peer):
                return False
            del self._advertised[name]
            advertised.withdrawn = True
            running = list(advertised.goals.values())
            advertised.goals.clear()
        for goal in running:
            if not goal.answer.done():
                goal.answer.set_result(None)
        # the aborted goals answer their callers before the server goes
        deadline = time.monotonic() + WITHDRAW_WAIT
        while any(not g.handle.done for g in running) and time.monotonic() < deadline:
            time.sleep(0.005)
        if advertised.server is not None:
            advertised.server.close()
        if running:
            _log.info('action %s withdrawn: %d running goals aborted', name, len(running))
        return True

    # --- the graph's side --------------------------------------------------------------------

    def _execute(self, advertised: _Advertised) -> Callable[[ServerGoalHandle], Awaitable[Message]]:
        async def execute(handle: ServerGoalHandle) -> Message:
            goal_id = f'action_goal:{advertised.text}:{next(self._ids)}'
            running = _Running(handle)
            with self._lock:
                refused = advertised.withdrawn or len(advertised.goals) >= MAX_GOALS
                if not refused:
                    advertised.goals[goal_id] = running
            if refused:
                _log.warning('action %s: goal aborted (withdrawn, or too many)', advertised.name)
                handle.abort()
                return handle.server.Result()
            try:
                advertised.peer.send(
                    {
                        'op': 'send_action_goal',
                        'id': goal_id,
                        'action': advertised.text,
                        'action_type': advertised.type_text,
                        'args': self._values.to_json(handle.request),
                        'feedback': True,
                    }
                )
                if handle.is_cancel_requested:  # canceled before it reached the client
                    self._send_cancel(advertised, goal_id, running)
                outcome = await asyncio.wrap_future(running.answer)
            finally:
                with self._lock:
                    advertised.goals.pop(goal_id, None)
            return _end(handle, outcome)

        return execute

    def _cancel(self, advertised: _Advertised) -> Callable[[ServerGoalHandle], bool]:
        def cancel(handle: ServerGoalHandle) -> bool:
            with self._lock:
                named = [(i, r) for i, r in advertised.goals.items() if r.handle is handle]
            for goal_id, running in named:
                self._send_cancel(advertised, goal_id, running)
            return True  # the client ends the goal, canceled or not

        return cancel

    def _send_cancel(self, advertised: _Advertised, goal_id: str, running: _Running) -> None:
        with self._lock:
            if running.cancel_sent:
                return
            running.cancel_sent = True
        advertised.peer.send({'op': 'cancel_action_goal', 'id': goal_id, 'action': advertised.text})

    # --- the client's answers ----------------------------------------------------------------

    def _goal(self, peer: Peer, op: JsonObject, pop: bool) -> tuple[_Advertised, str, _Running]:
        name = self._resolve(text_field(op, 'action'), 'action')
        goal_id = text_field(op, 'id')
        with self._lock:
            advertised = self._advertised.get(name)
            if advertised is None or advertised.peer is not peer:
                raise GatewayError(f'Action {name} has not been advertised via rosbridge.')
            running = advertised.goals.pop(goal_id, None) if pop else advertised.goals.get(goal_id)
        if running is None:
            raise GatewayError(f'Received {op["op"]} for unrecognized id: {goal_id}')
        return advertised, goal_id, running

    def action_feedback(self, peer: Peer, op: JsonObject) -> None:
        """An ``action_feedback`` message: feedback of a goal the client runs."""
        _, _, running = self._goal(peer, op, pop=False)
        handle = running.handle
        handle.publish_feedback(self._convert(handle.server.Feedback, op.get('values')))

    def action_result(self, peer: Peer, op: JsonObject) -> None:
        """An ``action_result`` message: the end of a goal the client ran."""
        advertised, goal_id, running = self._goal(peer, op, pop=True)
        handle = running.handle
        status, problem = _status(op, handle)
        try:
            result = self._convert(handle.server.Result, op.get('values'))
        except GatewayError as exc:
            result, status = handle.server.Result(), GoalStatus.ABORTED
            problem = problem or str(exc)
        running.answer.set_result((status, result))
        if problem:
            raise GatewayError(f'goal {goal_id} of {advertised.name} was aborted: {problem}')

    # --- lifetime ----------------------------------------------------------------------------

    def drop(self, peer: Peer) -> None:
        """A client left: its actions are withdrawn and their goals aborted."""
        with self._lock:
            names = [n for n, a in self._advertised.items() if a.peer is peer]
        for name in names:
            self._withdraw(name, peer)

    def close(self) -> None:
        """Withdraw every action."""
        with self._lock:
            names = list(self._advertised)
        for name in names:
            self._withdraw(name, None)


def _status(op: JsonObject, handle: ServerGoalHandle) -> tuple[GoalStatus, str]:
    """How an ``action_result`` ends its goal, and what was wrong with it ('' if nothing)."""
    if op['result'] is False:
        return GoalStatus.ABORTED, ''
    status = op.get('status', int(GoalStatus.SUCCEEDED))  # roslib before 2 sends none
    if (
        isinstance(status, bool)
        or not isinstance(status, int)
        or status not in [int(s) for s in ENDS]
    ):
        return GoalStatus.ABORTED, f'the status {status!r} is none of 4, 5, 6'
    end = GoalStatus(status)
    if end is GoalStatus.CANCELED and not handle.is_cancel_requested:
        return GoalStatus.ABORTED, 'it was not asked to cancel (status 5)'
    return end, ''


def _end(handle: ServerGoalHandle, outcome: _Outcome) -> Message:
    """End ``handle`` as the client said (aborted when withdrawn); its Result."""
    if outcome is None:
        handle.abort()
        return handle.server.Result()
    status, result = outcome
    try:
        if status is GoalStatus.SUCCEEDED:
            handle.succeed()
        elif status is GoalStatus.CANCELED:
            handle.canceled()
        else:
            handle.abort()
    except ActionError:  # a state the goal left meanwhile: abort is always allowed while running
        _log.warning('goal %s could not become %s: aborted', handle.goal_uuid, status.name)
        handle.abort()
    return result
