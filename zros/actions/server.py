"""Action servers: goals accepted over ``send_goal``, run by an execute callback, their results
held for ``get_result``, their states published on ``status``.

Queries are handled on Zenoh's threads where no user code is involved (``get_result``, and
``send_goal``/``cancel_goal`` without a goal or cancel callback), so a server works whether or not
its node spins. Goal and cancel callbacks run on the spinning thread. Each goal's execute
callback runs on a thread of its own (async ones on the node's event loop), so goals run
concurrently and a long goal never blocks the node.
"""

from __future__ import annotations

import collections
import concurrent.futures
import logging
import threading
import time
from collections.abc import Callable

from zenoh import Query, ZError

from zros.actions.action_entity import ActionEntity
from zros.actions.common import CancelReturn, GoalStatus, accepted, goal_id_of
from zros.actions.goals import cancel_candidates, run_goal
from zros.actions.server_goal import GoalRecord, ServerGoalHandle
from zros.cdr import CdrError
from zros.cdr.interfaces import ActionType
from zros.cdr.message import Message, decode, encode
from zros.cdr.registry import registry_of
from zros.keyexpr.kinds import EntityKind
from zros.pubsub import Publisher
from zros.qos import Durability, QoS
from zros.runtime.defaults import NodeLike
from zros.runtime.signal import Signal
from zros.services import ERROR_PREFIX

__all__ = ['MAX_FINISHED', 'ActionServer', 'ServerGoalHandle']

_log = logging.getLogger('zros')

#: finished goals a server remembers at most (older ones are forgotten first)
MAX_FINISHED = 1000


class ActionServer(ActionEntity):
    """An action server (rclpy: ``ActionServer``).

    ``execute_callback(goal_handle)`` runs each accepted goal and returns its Result.
    ``goal_callback(goal)`` decides whether to accept a goal (default: accept);
    ``cancel_callback(goal_handle)`` whether to accept a cancel request (default: accept, the goal
    then sees ``is_cancel_requested``). Both return a ``GoalResponse``/``CancelResponse`` or a
    bool. Finished goals stay queryable for ``result_timeout`` seconds.

    ``(name, type)`` as :class:`zros.Subscriber` takes them, ``node`` None the default node of
    ``zros.init``; ``node.create_action_server(type, name, ...)`` takes rclpy's order (rclpy's own
    ``ActionServer(node, type, name)`` puts the node first). Both ways are on purpose.
    """

    def __init__(
        self,
        name: str,
        action: str | ActionType,
        execute_callback: Callable[[ServerGoalHandle], object],
        *,
        goal_callback: Callable[[Message], object] | None = None,
        cancel_callback: Callable[[ServerGoalHandle], object] | None = None,
        node: NodeLike | None = None,
        result_timeout: float = 900.0,
        announce: bool = True,
    ) -> None:
        super().__init__(node)
        self._name_action(EntityKind.ACTION_SERVER, name, action)
        context = self.context
        wire = context.wire
        #: through a bridge one AS token announces the action; under rmw_zenoh its parts do
        parts_announced = announce and wire.announces_action_parts()
        self.execute_callback = execute_callback
        self.goal_callback = goal_callback
        self.cancel_callback = cancel_callback
        self.result_timeout = result_timeout
        registry = context.registry
        self._SendGoal = self.action_type.SendGoal
        self._GetResult = self.action_type.GetResult
        self._CancelGoal = registry.get_service('action_msgs/srv/CancelGoal')
        self._GoalStatus = registry.get_class('action_msgs/msg/GoalStatus')
        self._GoalInfo = registry.get_class('action_msgs/msg/GoalInfo')
        self._lock = threading.RLock()
        self._status_lock = threading.Lock()
        self._goals: collections.OrderedDict[bytes, GoalRecord] = collections.OrderedDict()
        self._warned_bad = False
        self._expiry_thread: threading.Thread | None = None
        self._expiry_signal = Signal()
        part = f'{self.name}/_action/'
        owner = self.node
        self._feedback = Publisher(
            part + 'feedback', self.action_type.FeedbackMessage, QoS(10), node=owner,
            announce=parts_announced,
        )  # fmt: skip
        self._status = Publisher(
            part + 'status', self._StatusArray, QoS(1, durability=Durability.TRANSIENT_LOCAL),
            node=owner, announce=parts_announced,
        )  # fmt: skip
        self._part(self._feedback)
        self._part(self._status)
        for service, srv, handler in (
            ('send_goal', self._SendGoal, self._on_send_goal),
            ('cancel_goal', self._CancelGoal, self._on_cancel_goal),
            ('get_result', self._GetResult, self._on_get_result),
        ):
            place = self._place(
                EntityKind.SERVICE_SERVER, part + service, srv.__srvtype__,
                registry_of(srv.Request), announce=parts_announced,
            )  # fmt: skip
            if service == 'send_goal':  # one admission for the three (shared pending requests)
                self._requests = place.requests(self.name, ERROR_PREFIX)
            self._serve(place, self._admitted(handler))
        if announce and not parts_announced:
            self._add_tokens(
                wire.action_tokens(EntityKind.ACTION_SERVER, self.name, self.type_name, registry)
            )
        self._announce()

    # --- helpers -------------------------------------------------------------------------------

    def _decode(self, query: Query, cls: type[Message]) -> Message | None:
        payload = query.payload
        try:
            return decode(cls, payload.to_bytes() if payload is not None else b'')
        except CdrError as exc:
            reason = f'a request to {self.name} does not decode as {cls.__msgtype__}: {exc}'
            if not self._warned_bad:
                self._warned_bad = True
                _log.warning('%s (reported once)', reason)
            self._fail(query, reason)
            return None

    def _admitted(self, handler: Callable[[Query], None]) -> Callable[[Query], None]:
        """``handler`` for the queries that pass the wire's rules (rmw_zenoh attachments)."""

        def on_query(query: Query) -> None:
            if self._requests.admit(query):
                handler(query)

        return on_query

    def _reply(self, query: Query, message: Message) -> None:
        self._requests.reply(query, encode(message))

    def _fail(self, query: Query, reason: str) -> None:
        self._requests.fail(query, reason)

    def _goal_info(self, handle: ServerGoalHandle) -> Message:
        info = self._GoalInfo()
        info.goal_id.uuid = handle.goal_id
        info.stamp = handle.stamp.to_msg()
        return info

    def _publish_status(self) -> None:
        # arrays go out one at a time, in order, but without the goals' lock: get_result
        # queries take it on Zenoh's thread and must not wait for a congested network
        with self._status_lock:
            with self._lock:
                if self._closed:
                    return
                statuses = [
                    self._GoalStatus(goal_info=self._goal_info(g.handle), status=int(g.status))
                    for g in self._goals.values()
                ]
            try:
                self._status.write(self._StatusArray(status_list=statuses))
            except ZError:  # the session closes under it
                _log.debug('cannot publish the status of %s', self.name, exc_info=True)

    def _expire(self) -> float | None:
        """Forget goals finished more than ``result_timeout`` ago (or beyond MAX_FINISHED);
        returns the seconds until the next one is due, None when none is finished."""
        now = time.monotonic()
        with self._lock:
            finished = [g for g in self._goals.values() if g.done]
            old = [g for g in finished if now - g.finished_at >= self.result_timeout]
            kept = [g for g in finished if g not in old]
            old += kept[: max(0, len(kept) - MAX_FINISHED)]
            for goal in old:
                self._goals.pop(goal.handle.goal_id, None)
            due = [g.finished_at + self.result_timeout - now for g in kept if g not in old]
        if old:
            self._publish_status()
        return min(due, default=None)

    def _expiry_loop(self) -> None:
        while not self._closed:
            wait = self._expire()
            self._expiry_signal.wait(lambda: self._closed, wait)

    def _start_expiry(self) -> None:
        with self._lock:
            if self._expiry_thread is None and not self._closed:
                self._expiry_thread = threading.Thread(
                    target=self._expiry_loop, name=f'zros results {self.name}', daemon=True
                )
                self._expiry_thread.start()
        self._expiry_signal.notify()

    def _in_spin(self, function: Callable[[], object]) -> None:
        self.context.executor.call_soon(function)

    # --- send_goal -----------------------------------------------------------------------------

    def _on_send_goal(self, query: Query) -> None:
        request = self._decode(query, self._SendGoal.Request)
        if request is None:
            return
        if self.goal_callback is None:
            self._decide(query, request)
        else:
            self._in_spin(lambda: self._decide(query, request))

    def _decide(self, query: Query, request: Message) -> None:
        goal_id = goal_id_of(request.goal_id)
        answer = True
        if self.goal_callback is not None:
            try:
                answer = accepted(self.goal_callback(request.goal))
            except Exception:  # a user callback: logged, the goal rejected
                _log.exception('the goal callback of action %s raised: goal rejected', self.name)
                answer = False
        stamp = self.context.clock.now()
        with self._lock:
            if self._closed:
                answer = False
            elif goal_id in self._goals:
                _log.warning('action %s: goal id %s already used: rejected', self.name, goal_id)
                answer = False
            if answer:
                goal = GoalRecord(
                    self, goal_id, request.goal, stamp, lock=self._lock,
                    send_feedback=self._publish_feedback,
                )  # fmt: skip
                self._goals[goal_id] = goal
        self._reply(query, self._SendGoal.Response(accepted=answer, stamp=stamp.to_msg()))
        if answer:
            self._publish_status()
            self._execute(goal)

    # --- executing -------------------------------------------------------------------------------

    def _execute(self, goal: GoalRecord) -> None:
        goal.execute()  # a cancel that came between the accept's reply and now stays
        self._publish_status()
        run_goal(
            goal.handle, self.execute_callback, self.context.executor,
            lambda _, future: self._finished(goal, future),
        )  # fmt: skip

    def _finished(self, goal: GoalRecord, future: concurrent.futures.Future[object]) -> None:
        result_class = self.action_type.Result
        try:
            result = future.result()
        except BaseException as exc:
            _log.error(
                'the execute callback of action %s raised: goal %s aborted',
                self.name,
                goal.handle.goal_uuid,
                exc_info=exc,
            )
            self._finish(goal, result_class(), GoalStatus.ABORTED)
            return
        if result is None:
            result = result_class()
        if type(result) is not result_class:
            got = getattr(result, '__msgtype__', type(result).__name__)
            _log.error(
                'the execute callback of action %s returned %s, not %s: goal %s aborted',
                self.name,
                got,
                result_class.__msgtype__,
                goal.handle.goal_uuid,
            )
            self._finish(goal, result_class(), GoalStatus.ABORTED)
            return
        self._finish(goal, result, None)

    def _finish(self, goal: GoalRecord, result: Message, forced: GoalStatus | None) -> None:
        status, waiters = goal.finish(result, forced)
        response = self._GetResult.Response(status=int(status), result=result)
        for query in waiters:
            self._reply(query, response)
        self._publish_status()
        self._start_expiry()

    def _publish_feedback(
        self, handle: ServerGoalHandle, feedback: Message | None, fields: dict[str, object]
    ) -> None:
        feedback_class = self.action_type.Feedback
        if feedback is None:
            feedback = feedback_class(**fields)
        elif fields:
            raise TypeError('give a feedback message or its fields, not both')
        elif type(feedback) is not feedback_class:
            got = getattr(feedback, '__msgtype__', type(feedback).__name__)
            raise TypeError(f'{self.name} sends {feedback_class.__msgtype__} feedback, not {got}')
        if self._closed or not handle.is_active:
            return
        message = self.action_type.FeedbackMessage(feedback=feedback)
        message.goal_id.uuid = handle.goal_id
        self._feedback.write(message)

    # --- get_result ----------------------------------------------------------------------------

    def _on_get_result(self, query: Query) -> None:
        request = self._decode(query, self._GetResult.Request)
        if request is None:
            return
        with self._lock:
            closed = self._closed
            goal = self._goals.get(goal_id_of(request.goal_id))
            if goal is not None and not closed and goal.hold(query):
                return
        if closed:
            self._fail(query, f'the action server {self.name} closed')
            return
        if goal is None:
            response = self._GetResult.Response(status=int(GoalStatus.UNKNOWN))
        else:
            response = self._GetResult.Response(status=int(goal.status), result=goal.result)
        self._reply(query, response)

    # --- cancel_goal ---------------------------------------------------------------------------

    def _on_cancel_goal(self, query: Query) -> None:
        request = self._decode(query, self._CancelGoal.Request)
        if request is None:
            return
        if self.cancel_callback is None:
            self._cancel(query, request)
        else:
            self._in_spin(lambda: self._cancel(query, request))

    def _cancel(self, query: Query, request: Message) -> None:
        candidates, error = cancel_candidates(self.goals, request)
        canceling = []
        for handle in candidates:
            answer = True
            if self.cancel_callback is not None:
                try:
                    answer = accepted(self.cancel_callback(handle))
                except Exception:  # a user callback: logged, the cancel refused
                    _log.exception('the cancel callback of action %s raised: refused', self.name)
                    answer = False
            if not answer:
                continue
            with self._lock:
                goal = self._goals.get(handle.goal_id)
                if goal is not None and goal.cancel():
                    canceling.append(handle)
        if error is None:
            error = int(CancelReturn.NONE if canceling or not candidates else CancelReturn.REJECTED)
        response = self._CancelGoal.Response(
            return_code=error, goals_canceling=[self._goal_info(g) for g in canceling]
        )
        self._reply(query, response)
        if canceling:
            self._publish_status()

    # --- lifetime ------------------------------------------------------------------------------

    @property
    def goals(self) -> list[ServerGoalHandle]:
        """The goals the server knows: running ones and finished ones not yet forgotten."""
        with self._lock:
            return [goal.handle for goal in self._goals.values()]

    def close(self) -> None:
        """Withdraw the server; held get_result calls get an error, running goals are left to
        end on their own (their feedback goes nowhere)."""
        super().close()

    def _on_close(self) -> None:
        with self._lock:
            waiters = [q for goal in self._goals.values() for q in goal.release()]
        self._expiry_signal.notify()
        for query in waiters:
            self._fail(query, f'the action server {self.name} closed')

    def __repr__(self) -> str:
        return f'<zros ActionServer {self.name} [{self.type_name}]>'
