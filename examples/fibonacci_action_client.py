"""An action client: send ``fibonacci`` goals, follow their feedback, cancel one.

``send_goal(order=10, feedback_callback=...)`` returns a goal handle once the server accepted
the goal (``handle.accepted``); ``handle.result(timeout)`` waits for the Result message and
``handle.status`` says how the goal ended. Feedback callbacks run where the node spins, while
``handle.status`` and ``handle.feedback`` (the latest) update by themselves.

Start ``fibonacci_action_server.py`` (or ``ros2 run action_tutorials_py fibonacci_action_server``
behind a bridge) on the same router or robot (``--connect`` or ``ZROS_CONNECT``). With neither,
this script starts a Zenoh router and a server of its own.
"""

from __future__ import annotations

import argparse

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros


def main() -> int:
    parser = argparse.ArgumentParser(
        description='send goals to the fibonacci action', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--order', type=int, default=10, help='how many numbers to ask for')
    args = parser.parse_args()
    router, args.connect = router_unless_given(args.connect, 'a server')

    zros.init('fibonacci_action_client', connect=args.connect)
    if router is not None:  # a stand-in for fibonacci_action_server.py on a node of its own;
        from fibonacci_action_server import execute  # its goals run on threads of their own

        server_node = zros.Node('fibonacci_action_server')
        server_node.create_action_server(
            'example_interfaces/action/Fibonacci', 'fibonacci', execute
        )

    client = zros.ActionClient('fibonacci', 'example_interfaces/action/Fibonacci')
    if not client.wait_for_server(timeout=10):
        print('no fibonacci action server answered within 10 s')
        return 1

    feedback_count = 0

    def on_feedback(feedback: zros.cdr.Message) -> None:
        nonlocal feedback_count
        feedback_count += 1
        print(f'Feedback: {feedback.sequence.tolist()}')

    goal = client.send_goal(order=args.order, feedback_callback=on_feedback)
    print(f'Goal accepted: {goal.accepted}')
    while not goal.done:
        zros.spin_once(timeout=0.1)  # feedback callbacks run in here
    print(f'Result: {goal.result().sequence.tolist()} ({goal.status.name})')

    # a second, longer goal, canceled once it has made some progress
    long_goal = client.send_goal(order=40)
    while zros.ok() and not long_goal.done:  # handle.feedback follows without spinning
        if long_goal.feedback is not None and len(long_goal.feedback.sequence) >= 5:
            break
        zros.spin_once(timeout=0.05)
    print(f'Cancel requested: {long_goal.cancel(timeout=5)}')
    result = long_goal.result(timeout=10)
    print(f'The long goal ended {long_goal.status.name} with {len(result.sequence)} numbers')
    zros.shutdown()
    if router is not None:
        router.close()
    return 0 if feedback_count and long_goal.status is zros.GoalStatus.CANCELED else 1


if __name__ == '__main__':
    raise SystemExit(main())
