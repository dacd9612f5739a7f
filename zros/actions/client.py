"""Action clients: send goals, follow their feedback and status, get their results, cancel them.

Feedback and status are decoded on Zenoh's threads and kept on the goal handle, so polling
(``handle.status``, ``handle.feedback``, ``handle.result(timeout)``) works without spinning;
a ``feedback_callback`` runs on the thread that spins the node.
"""

from __future__ import annotations

import collections
import concurrent.futures
import logging
import threading
import time
import weakref
from collections.abc import Callable

from zenoh import Sample

from zros.actions.action_entity import ActionEntity
from zros.actions.common import (
    CancelReturn,
    GoalHandle,
    GoalStatus,
    goal_id_of,
    new_goal_id,
)
from zros.actions.errors import ActionError, GoalRejectedError
from zros.cdr import CdrError
from zros.cdr.interfaces import ActionType
from zros.cdr.message import Message, decode
from zros.cdr.registry import registry_of
from zros.keyexpr.kinds import EntityKind
from zros.qos import Durability, QoS
from zros.runtime.clock import Time
from zros.runtime.defaults import NodeLike
from zros.runtime.executor import Work
from zros.runtime.futures import ServiceFuture
from zros.runtime.signal import Signal
from zros.runtime.timeouts import UNSET, Unset, either_timeout
from zros.services import Client, ServiceError

_log = logging.getLogger('zros')

#: how long a client waits for a result by default: goals may run for hours
RESULT_TIMEOUT = 30 * 24 * 3600.0

#: feedback messages waiting for their callbacks, per client: the newest are kept, as rclpy's
#: feedback subscription (keep last 10) keeps them, so a node that does not spin holds no more
FEEDBACK_DEPTH = 10


class ClientGoalHandle(GoalHandle):
    """A goal sent by an :class:`ActionClient`: its state, latest feedback and result."""

    def __init__(
        self,
        client: ActionClient,
        goal_id: bytes,
        goal: Message,
        feedback_callback: Callable[[Message], object] | None,
    ) -> None:
        super().__init__(goal_id, None)
        self._status = GoalStatus.UNKNOWN
        self.client = client
        self.goal = goal
        self.accepted = False
        self.feedback: Message | None = None  #: the latest Feedback message
        self.feedback_count = 0
        self._feedback_callback = feedback_callback
        self._result: ServiceFuture[Message] = ServiceFuture()
        self._changed = Signal()
        self._lock = threading.Lock()

    @property
    def status(self) -> GoalStatus:
        """The goal's current state."""
        return self._status

    @property
    def done(self) -> bool:
        """Whether the result (or the reason there is none) is known."""
        return self._result.done()

    # --- what its ActionClient tells it (on Zenoh's threads) ----------------------------------

    def _set_status(self, status: GoalStatus) -> None:
        # a goal's states only move forward (ACCEPTED < EXECUTING < CANCELING < the ends); an
        # older status array (a transient-local history reply) must not take it back
        with self._lock:
            if self._result.done() or self._status.terminal or status <= self._status:
                return
            self._status = status
        self._changed.notify()

    def _on_feedback(self, feedback: Message) -> Callable[[Message], object] | None:
        """Keep ``feedback`` as the latest; the callback to run with it, if any."""
        self.feedback = feedback
        self.feedback_count += 1
        return self._feedback_callback

    def _fail(self, error: BaseException) -> None:
        """The goal has no result: waiting for it raises ``error``."""
        self._result.settle(error)
        self._changed.notify()

    def _finish(self, status: GoalStatus, result: Message) -> None:
        """The server's result, with the terminal status it gave (which stands over any the
        status topic told)."""
        with self._lock:
            self._status = status
            self._result.settle(result)
        self._changed.notify()

    def result(self, timeout: float | None = None) -> Message:
        """Wait for the goal to end and return its Result message (``status`` says how it
        ended); raises TimeoutError, ActionError when the goal was rejected or lost, and
        KeyboardInterrupt after Ctrl-C."""
        try:
            result: Message = self._result.result(timeout)
            return result
        except concurrent.futures.TimeoutError:
            raise TimeoutError(
                f'goal {self.goal_uuid} of {self.client.name} did not end within {timeout:g} s'
            ) from None

    def result_async(self) -> ServiceFuture[Message]:
        """A future of the Result message, to ``await`` or ``.result()``."""
        return self._result

    def wait_for_status(
        self, predicate: Callable[[GoalStatus], bool], timeout: float | None = None
    ) -> bool:
        """Wait until ``predicate(status)`` holds; returns whether it did in time (False after
        Ctrl-C)."""
        return self._changed.wait_for(lambda: predicate(self._status), timeout)

    def cancel(self, timeout: float | None = None) -> bool:
        """Ask the server to cancel the goal; returns whether it agreed (the goal then ends
        with status CANCELED once its execute callback gives up)."""
        response = self.client._cancel_goal(self.goal_id, timeout)
        return response.return_code == CancelReturn.NONE and any(
            goal_id_of(info.goal_id) == self.goal_id for info in response.goals_canceling
        )

    def __repr__(self) -> str:
        return f'<zros goal {self.goal_uuid} of {self.client.name}: {self._status.name}>'


class ActionClient(ActionEntity):
    """An action client (rclpy: ``ActionClient``).

    ``send_goal(goal)`` (or ``send_goal(order=10)``) returns a :class:`ClientGoalHandle` once the
    server accepted or rejected the goal; ``handle.result(timeout)`` waits for the result.
    ``feedback_callback(feedback)`` gets each Feedback message while the node spins.

    ``(name, type)`` as :class:`zros.Subscriber` takes them, ``node`` None the default node of
    ``zros.init``; ``node.create_action_client(type, name, ...)`` takes rclpy's order (rclpy's own
    ``ActionClient(node, type, name)`` puts the node first). Both ways are on purpose.
    """

    def __init__(
        self,
        name: str,
        action: str | ActionType,
        *,
        node: NodeLike | None = None,
        announce: bool = True,
    ) -> None:
        super().__init__(node)
        self._name_action(EntityKind.ACTION_CLIENT, name, action)
        context = self.context
        wire = context.wire
        registry = context.registry
        self._FeedbackMessage = self.action_type.FeedbackMessage
        self._handles: weakref.WeakValueDictionary[bytes, ClientGoalHandle] = (
            weakref.WeakValueDictionary()
        )
        self._lock = threading.Lock()
        self._feedback_due: collections.deque[tuple[Callable[[Message], object], Message]] = (
            collections.deque(maxlen=FEEDBACK_DEPTH)
        )
        self._feedback_work = Work(self._run_feedback)
        part = f'{self.name}/_action/'
        parts = announce and wire.announces_action_parts()
        owner = self.node
        self._send_goal = Client(part + 'send_goal', self.action_type.SendGoal, node=owner,
                                 announce=parts)  # fmt: skip
        self._get_result = Client(part + 'get_result', self.action_type.GetResult, node=owner,
                                  announce=parts)  # fmt: skip
        self._cancel = Client(part + 'cancel_goal', 'action_msgs/srv/CancelGoal', node=owner,
                              announce=parts)  # fmt: skip
        self._services = (self._send_goal, self._get_result, self._cancel)
        for service in self._services:
            self._part(service)
        subscriber = EntityKind.SUBSCRIBER
        status_qos = QoS(1, durability=Durability.TRANSIENT_LOCAL)
        feedback = self._place(
            subscriber, part + 'feedback', self._FeedbackMessage.__msgtype__,
            registry_of(self._FeedbackMessage), qos=QoS(10), announce=parts,
        )  # fmt: skip
        status = self._place(
            subscriber, part + 'status', self._StatusArray.__msgtype__,
            registry_of(self._StatusArray), qos=status_qos, announce=parts,
        )  # fmt: skip
        self._subscribe(feedback, QoS(10), self._on_feedback)
        # the statuses that matter are those of goals sent to servers present then: no late
        # publisher detection, which in zenoh-ext 1.10 leaks ~100 KiB per matched advanced
        # publisher on undeclaration (tests/faults/test_leaks.py)
        self._subscribe(status, status_qos, self._on_status, late_publishers=False)
        if announce and not parts:
            self._add_tokens(
                wire.action_tokens(EntityKind.ACTION_CLIENT, self.name, self.type_name, registry)
            )
        self._announce()

    # --- the server ----------------------------------------------------------------------------

    def server_is_ready(self) -> bool:
        """Whether the goal, result and cancel services of a server are all reachable."""
        return all(service.service_is_ready() for service in self._services)

    def wait_for_server(
        self, timeout: float | None = 5.0, *, timeout_sec: float | Unset | None = UNSET
    ) -> bool:
        """Wait until ``server_is_ready()``; returns whether it became so in time.
        ``timeout_sec`` is rclpy's spelling of ``timeout``."""
        timeout = either_timeout(timeout, timeout_sec, 5.0)
        deadline = None if timeout is None else time.monotonic() + timeout
        for service in self._services:
            remaining = None if deadline is None else max(0.0, deadline - time.monotonic())
            if not service.wait_for_service(remaining):
                return False
        return True

    # --- on Zenoh's threads --------------------------------------------------------------------

    def _on_feedback(self, sample: Sample) -> None:
        try:
            message = decode(self._FeedbackMessage, sample.payload.to_bytes())
        except CdrError as exc:
            _log.debug('dropped feedback of %s that does not decode: %s', self.name, exc)
            return
        handle = self._handles.get(goal_id_of(message.goal_id))
        if handle is None:
            return
        callback = handle._on_feedback(message.feedback)
        if callback is not None:
            self._feedback_due.append((callback, message.feedback))
            self.context.executor.queue(self._feedback_work)

    def _run_feedback(self) -> int:
        # on the spinning thread: the feedback callbacks due, oldest first
        done = 0
        while self._feedback_due:
            try:
                callback, feedback = self._feedback_due.popleft()
            except IndexError:  # taken meanwhile (the client closed)
                break
            try:
                callback(feedback)
            except Exception:  # a user callback: logged, the executor goes on
                _log.exception('feedback callback %r raised', callback)
            done += 1
        return done

    def _on_status(self, sample: Sample) -> None:
        try:
            message = decode(self._StatusArray, sample.payload.to_bytes())
        except CdrError as exc:
            _log.debug('dropped a status of %s that does not decode: %s', self.name, exc)
            return
        for entry in message.status_list:
            handle = self._handles.get(goal_id_of(entry.goal_info.goal_id))
            if handle is not None:
                try:
                    status = GoalStatus(entry.status)
                except ValueError:
                    continue
                handle._set_status(status)

    # --- goals ---------------------------------------------------------------------------------

    def _goal(self, goal: Message | None, fields: dict[str, object]) -> Message:
        goal_class = self.action_type.Goal
        if goal is None:
            return goal_class(**fields)
        if fields:
            raise TypeError('give a goal or its fields, not both')
        if type(goal) is not goal_class:
            got = getattr(goal, '__msgtype__', type(goal).__name__)
            raise TypeError(f'{self.name} takes {goal_class.__msgtype__} goals, not {got}')
        return goal

    def send_goal_async(
        self,
        goal: Message | None = None,
        feedback_callback: Callable[[Message], object] | None = None,
        timeout: float | None = None,
        **fields: object,
    ) -> ServiceFuture[ClientGoalHandle]:
        """Send a goal; a future of its :class:`ClientGoalHandle` once the server answered."""
        if self._closed:
            raise ActionError(f'the action client of {self.name} was closed')
        goal_message = self._goal(goal, fields)
        handle = ClientGoalHandle(self, new_goal_id(), goal_message, feedback_callback)
        with self._lock:
            self._handles[handle.goal_id] = handle
        request = self._send_goal.Request(goal=goal_message)
        request.goal_id.uuid = handle.goal_id
        answered: ServiceFuture[ClientGoalHandle] = ServiceFuture()

        def on_answer(future: concurrent.futures.Future[Message]) -> None:
            try:
                response = future.result()
            except KeyboardInterrupt as exc:  # Ctrl-C: the handle fails with it too
                answered.settle(exc)
                return
            except ServiceError as exc:
                handle._fail(ActionError(f'the goal of {self.name} was not delivered: {exc}'))
                answered.settle(exc)
                return
            handle.stamp = Time.from_msg(response.stamp)
            if not response.accepted:
                handle._fail(
                    GoalRejectedError(f'the server of {self.name} rejected goal {handle.goal_uuid}')
                )
                answered.settle(handle)
                return
            handle.accepted = True
            handle._set_status(GoalStatus.ACCEPTED)
            self._request_result(handle)
            answered.settle(handle)

        self._send_goal.call_async(request, timeout).add_done_callback(on_answer)
        return answered

    def send_goal(
        self,
        goal: Message | None = None,
        feedback_callback: Callable[[Message], object] | None = None,
        timeout: float | None = None,
        **fields: object,
    ) -> ClientGoalHandle:
        """Send a goal and return its handle once the server accepted or rejected it (check
        ``handle.accepted``); raises ServiceError subclasses when no server answers, and
        KeyboardInterrupt after Ctrl-C."""
        future = self.send_goal_async(goal, feedback_callback, timeout, **fields)
        wait = self._send_goal.timeout if timeout is None else timeout
        handle: ClientGoalHandle = future.result(wait + 5.0)
        return handle

    def _request_result(self, handle: ClientGoalHandle) -> None:
        request = self._get_result.Request()
        request.goal_id.uuid = handle.goal_id

        def no_result(exc: ServiceError) -> None:
            error = ActionError(f'no result for goal {handle.goal_uuid} of {self.name}: {exc}')
            handle._fail(error)

        def on_result(future: concurrent.futures.Future[Message]) -> None:
            try:
                response = future.result()
            except KeyboardInterrupt as exc:
                handle._fail(exc)
                return
            except ServiceError as exc:
                no_result(exc)
                return
            try:
                status = GoalStatus(response.status)
            except ValueError:
                status = GoalStatus.UNKNOWN
            if status is GoalStatus.UNKNOWN or not status.terminal:
                handle._fail(
                    ActionError(
                        f'the server of {self.name} does not know goal {handle.goal_uuid} '
                        f'(result status {response.status})'
                    )
                )
            else:
                handle._finish(status, response.result)

        try:
            pending = self._get_result.call_async(request, RESULT_TIMEOUT)
        except ServiceError as exc:  # the link dropped since the goal was accepted
            no_result(exc)
            return
        pending.add_done_callback(on_result)

    def _cancel_goal(self, goal_id: bytes, timeout: float | None) -> Message:
        request = self._cancel.Request()
        request.goal_info.goal_id.uuid = goal_id
        return self._cancel.call(request, timeout)

    def cancel_all_goals(self, timeout: float | None = None) -> list[bytes]:
        """Ask the server to cancel every goal; returns the ids of those being canceled."""
        response = self._cancel.call(self._cancel.Request(), timeout)
        return [goal_id_of(info.goal_id) for info in response.goals_canceling]

    # --- lifetime ------------------------------------------------------------------------------

    def close(self) -> None:
        """Withdraw the client; goals already sent keep running on the server."""
        super().close()
        self.context.executor.cancel(self._feedback_work)
        self._feedback_due.clear()

    def __repr__(self) -> str:
        return f'<zros ActionClient {self.name} [{self.type_name}]>'
