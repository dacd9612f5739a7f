"""Rules about goals that both live in no server state: which goals a cancel request names
(ROS 2's rules), and how a goal's execute callback runs."""

from __future__ import annotations

import concurrent.futures
import inspect
import threading
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, TypeVar

from zros.actions.common import CancelReturn, GoalHandle, goal_id_of
from zros.runtime.clock import Time
from zros.runtime.executor import Executor
from zros.transport.session import join_at_exit

if TYPE_CHECKING:
    from zros.cdr import Message

H = TypeVar('H', bound=GoalHandle)


def cancel_candidates(goals: Sequence[H], request: Message) -> tuple[list[H], int | None]:
    """The active goals an ``action_msgs/srv/CancelGoal`` request names, or the error code
    when none: by id, all goals accepted before its stamp, or (neither given) every goal."""
    info = request.goal_info
    goal_id = goal_id_of(info.goal_id)
    by_id = any(goal_id)
    before = Time.from_msg(info.stamp)
    named = [g for g in goals if by_id and g.goal_id == goal_id]
    if before.nanoseconds:
        named += [g for g in goals if g.stamp is not None and g.stamp <= before and g not in named]
    elif not by_id:
        named = list(goals)
    active = [g for g in named if g.status.active]
    if active:
        return active, None
    if by_id and not any(g.goal_id == goal_id for g in goals):
        return [], int(CancelReturn.UNKNOWN_GOAL_ID)
    if named:
        return [], int(CancelReturn.GOAL_TERMINATED)
    return [], int(CancelReturn.NONE)


def run_goal(
    handle: H,
    execute: Callable[[H], object],
    executor: Executor,
    finished: Callable[[H, concurrent.futures.Future[object]], None],
) -> None:
    """Run ``execute(handle)`` (a coroutine function on the executor's event loop, else on a
    thread of its own) and call ``finished(handle, future)`` with its outcome."""
    if inspect.iscoroutinefunction(execute):
        future = executor.run_coroutine(execute(handle))
        future.add_done_callback(lambda f: finished(handle, f))
        return

    def run() -> None:
        outcome: concurrent.futures.Future[object] = concurrent.futures.Future()
        try:
            result = execute(handle)
            if inspect.iscoroutine(result):
                result = executor.run_coroutine(result).result()
            outcome.set_result(result)
        except BaseException as exc:  # the user's callback: its failure is the outcome
            outcome.set_exception(exc)
        finished(handle, outcome)

    thread = threading.Thread(target=run, name=f'zros goal {handle.goal_uuid}', daemon=True)
    join_at_exit(thread)  # it replies and publishes the status once ``execute`` returns
    thread.start()
