"""An action server: ``fibonacci`` (``example_interfaces/action/Fibonacci``).

Each accepted goal runs ``execute(goal)`` on a thread of its own, so goals run side by side
and a long one never blocks the node. It reports the sequence so far as feedback at every step,
stops early when a client cancels, and returns the Result. A ROS 2 client behind
zenoh-bridge-ros2dds sends goals as to any server::

    ros2 action send_goal --feedback /fibonacci example_interfaces/action/Fibonacci "{order: 5}"

Start ``fibonacci_action_client.py`` on the same router or robot (``--connect`` or
``ZROS_CONNECT``). With neither, this script starts a Zenoh router and sends itself a goal
from a client on a node of its own.
"""

from __future__ import annotations

import argparse
import threading
import time

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros

STEP = 0.1  # seconds per number: a stand-in for real work


def execute(goal: zros.actions.ServerGoalHandle) -> zros.cdr.Message:
    """Compute the sequence of ``goal.request.order`` numbers, one step at a time."""
    print(f'Executing goal {goal.goal_uuid}: order {goal.request.order}')
    sequence = [0, 1]
    for _ in range(goal.request.order - 1):
        if goal.is_cancel_requested:
            goal.canceled()
            print(f'Goal {goal.goal_uuid} canceled after {len(sequence)} numbers')
            break
        sequence.append(sequence[-1] + sequence[-2])
        goal.publish_feedback(sequence=sequence)
        time.sleep(STEP)
    return goal.server.Result(sequence=sequence)


def send_one_goal(done: threading.Event) -> None:
    """A client on a node of its own (a stand-in for ``fibonacci_action_client.py``)."""
    node = zros.Node('fibonacci_caller')
    client = node.create_action_client('example_interfaces/action/Fibonacci', 'fibonacci')
    client.wait_for_server(timeout=5)
    goal = client.send_goal(order=8)
    print(f'  the client got {goal.result(timeout=10).sequence.tolist()} ({goal.status.name})')
    node.destroy()
    done.set()


def main() -> int:
    parser = argparse.ArgumentParser(
        description='serve the fibonacci action', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--count', type=int, default=0, help='stop after this many goals')
    parser.add_argument('--seconds', type=float, default=0, help='stop after this long (0: never)')
    args = parser.parse_args()
    done = threading.Event()
    router, args.connect = router_unless_given(args.connect, 'a client')

    zros.init('fibonacci_action_server', connect=args.connect)
    finished = 0

    def run_goal(goal: zros.actions.ServerGoalHandle) -> zros.cdr.Message:
        nonlocal finished
        try:
            return execute(goal)
        finally:
            finished += 1
            if finished == args.count:
                done.set()

    server = zros.ActionServer('fibonacci', 'example_interfaces/action/Fibonacci', run_goal)
    print('serving the fibonacci action')
    if router is not None:
        threading.Thread(target=send_one_goal, args=(done,), daemon=True).start()
    deadline = time.monotonic() + args.seconds if args.seconds else None
    while zros.ok() and not done.is_set():
        zros.spin_once(timeout=0.1)  # goal and cancel callbacks would run here; goals have threads
        if deadline is not None and time.monotonic() > deadline:
            break
    # let the last result reach its client before the server goes away
    while any(goal.is_active for goal in server.goals) and zros.ok():
        zros.spin_once(timeout=0.05)
    zros.shutdown()
    if router is not None:
        router.close()
    print(f'finished {finished} goals')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
