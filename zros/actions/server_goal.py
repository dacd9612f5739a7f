"""A goal on an action server: the handle its execute callback gets, and the server's record
of it.

The record holds what the server tracks of a goal (its state, its result once known, the
``get_result`` queries waiting for it) and makes every change under the server's lock, so the
handle's ``succeed``/``abort``/``canceled`` and the server's execute, cancel and finish steps
never interleave. The handle reads its state from the record and sends feedback through the
callable the server gave it; neither touches the server's private members.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Protocol

from zenoh import Query

from zros.actions.common import GoalHandle, GoalStatus
from zros.actions.errors import ActionError
from zros.cdr.interfaces import ActionType
from zros.cdr.message import Message
from zros.runtime.clock import Time


class GoalServer(Protocol):
    """What a goal handle shows of its action server (``goal.server.Result``)."""

    @property
    def name(self) -> str:
        """The action's name."""

    @property
    def action_type(self) -> ActionType:
        """The action type."""

    @property
    def Goal(self) -> type[Message]:  # noqa: N802 (the message class, as ROS names it)
        """The Goal message class."""

    @property
    def Result(self) -> type[Message]:  # noqa: N802
        """The Result message class."""

    @property
    def Feedback(self) -> type[Message]:  # noqa: N802
        """The Feedback message class."""


#: how a handle sends feedback: ``send(handle, feedback message or None, fields)``
SendFeedback = Callable[['ServerGoalHandle', Message | None, dict[str, object]], None]


class GoalRecord:
    """The server's record of one goal; every change happens under the server's ``lock``.

    The server reads ``status``, ``done``, ``result`` and ``finished_at`` while it holds the
    lock; the handle it makes is ``handle``.
    """

    def __init__(
        self,
        server: GoalServer,
        goal_id: bytes,
        request: Message,
        stamp: Time,
        *,
        lock: threading.RLock,
        send_feedback: SendFeedback,
    ) -> None:
        self._lock = lock
        self._send_feedback = send_feedback
        self.status = GoalStatus.ACCEPTED
        self.result: Message | None = None  #: the Result, once ``done``
        self.done = False  #: the result is known
        self.finished_at = 0.0  #: when the result became known (time.monotonic)
        self._waiters: list[Query] = []  #: get_result queries held until the result is known
        self.handle = ServerGoalHandle(server, goal_id, request, stamp, self)

    def send_feedback(self, feedback: Message | None, fields: dict[str, object]) -> None:
        """Send the handle's feedback through the server."""
        self._send_feedback(self.handle, feedback, fields)

    def move(self, status: GoalStatus, allowed: tuple[GoalStatus, ...]) -> GoalStatus:
        """Make the goal ``status`` if it is in one of the ``allowed`` states; returns the state
        it was in."""
        with self._lock:
            before = self.status
            if before in allowed:
                self.status = status
            return before

    def execute(self) -> None:
        """The execute callback starts: an accepted goal becomes EXECUTING (a goal whose cancel
        came first stays CANCELING)."""
        self.move(GoalStatus.EXECUTING, (GoalStatus.ACCEPTED,))

    def cancel(self) -> bool:
        """A cancel was accepted: an accepted or executing goal becomes CANCELING; returns
        whether the goal is canceling."""
        before = self.move(GoalStatus.CANCELING, (GoalStatus.ACCEPTED, GoalStatus.EXECUTING))
        return before in (GoalStatus.ACCEPTED, GoalStatus.EXECUTING, GoalStatus.CANCELING)

    def finish(self, result: Message, forced: GoalStatus | None) -> tuple[GoalStatus, list[Query]]:
        """The goal ended with ``result``: its final state (``forced``, else the one its handle
        chose, else CANCELED after a cancel, else SUCCEEDED) and the held queries to answer."""
        with self._lock:
            status = self.status
            if forced is not None:
                status = forced
            elif status is GoalStatus.CANCELING:
                status = GoalStatus.CANCELED
            elif not status.terminal:
                status = GoalStatus.SUCCEEDED
            self.status = status
            self.result = result
            self.done = True
            self.finished_at = time.monotonic()
            waiters, self._waiters = self._waiters, []
        return status, waiters

    def hold(self, query: Query) -> bool:
        """Keep a get_result query until the result is known; False when it is known already."""
        with self._lock:
            if self.done:
                return False
            self._waiters.append(query)
            return True

    def release(self) -> list[Query]:
        """The held get_result queries, forgotten (the server closes)."""
        with self._lock:
            waiters, self._waiters = self._waiters, []
        return waiters


class ServerGoalHandle(GoalHandle):
    """One goal on the server side, handed to the execute callback.

    Report progress with ``publish_feedback``; end with ``succeed()``, ``abort()`` or (after a
    cancel request, see ``is_cancel_requested``) ``canceled()``, and return the result. Returning
    without choosing means success, or canceled if a cancel was requested; raising means aborted.
    """

    def __init__(
        self,
        server: GoalServer,
        goal_id: bytes,
        request: Message,
        stamp: Time,
        record: GoalRecord,
    ) -> None:
        super().__init__(goal_id, stamp)
        self.server = server
        self.request = request  #: the Goal message
        self.stamp: Time = stamp  #: when the server accepted it
        self._record = record

    @property
    def status(self) -> GoalStatus:
        """The goal's current state."""
        return self._record.status

    @property
    def is_active(self) -> bool:
        """Whether the goal still runs (accepted, executing or canceling)."""
        return self._record.status.active

    @property
    def done(self) -> bool:
        """Whether the goal's result is known (``get_result`` answers with it)."""
        return self._record.done

    @property
    def is_cancel_requested(self) -> bool:
        """Whether a client asked to cancel (and the cancel callback agreed)."""
        return self._record.status is GoalStatus.CANCELING

    def publish_feedback(self, feedback: Message | None = None, **fields: object) -> None:
        """Send feedback to the clients (a Feedback message, or its fields)."""
        self._record.send_feedback(feedback, fields)

    def _end(self, status: GoalStatus, allowed: tuple[GoalStatus, ...]) -> None:
        before = self._record.move(status, allowed)
        if before not in allowed:
            raise ActionError(
                f'goal {self.goal_uuid} is {before.name.lower()}: it cannot become '
                f'{status.name.lower()}'
            )

    def succeed(self) -> None:
        """End the goal as succeeded; return its result after."""
        self._end(GoalStatus.SUCCEEDED, (GoalStatus.EXECUTING, GoalStatus.CANCELING))

    def abort(self) -> None:
        """End the goal as aborted (it failed); return its result after."""
        self._end(GoalStatus.ABORTED, (GoalStatus.EXECUTING, GoalStatus.CANCELING))

    def canceled(self) -> None:
        """End a goal whose cancel was requested."""
        self._end(GoalStatus.CANCELED, (GoalStatus.CANCELING,))

    def __repr__(self) -> str:
        return f'<zros goal {self.goal_uuid} {self.status.name}>'
