"""Behaviour across processes: bursts through a router, exiting, Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import zros
from tests.support.processes import launch
from zros.node import Node
from zros.qos import KEEP_ALL
from zros.testing import wait_for
from zros.transport import Router


def test_a_keep_all_burst_of_100000_arrives_complete_and_in_order(
    zros_router: Router, zros_node: object
) -> None:
    listener: Node = zros_node('listener')  # type: ignore[operator]
    sub = listener.create_subscription('std_msgs/msg/UInt64', 'burst', qos=KEEP_ALL)
    publisher = launch(
        """
        import zros
        node = zros.Node('burst_talker')
        pub = node.create_publisher('std_msgs/msg/UInt64', 'burst', qos='keep_all')
        assert pub.wait_for_subscribers(10)
        message = zros.Message('std_msgs/msg/UInt64')
        for i in range(100_000):
            message.data = i
            pub.write(message)
        print('sent', flush=True)
        """,
        zros_router,
    )
    received: list[int] = []
    deadline = time.monotonic() + 120
    while len(received) < 100_000 and time.monotonic() < deadline:
        batch = sub.take()
        if not batch:
            first = sub.wait_for_message(0.5)
            batch = [] if first is None else [first]
        received.extend(m.data for m in batch)
    out, err = publisher.communicate(timeout=60)
    assert publisher.returncode == 0, err
    assert 'sent' in out
    assert len(received) == 100_000
    assert received == list(range(100_000))


def test_a_script_that_never_calls_shutdown_still_exits(zros_router: Router) -> None:
    script = launch(
        """
        import zros
        zros.init('forgetful')
        got = []
        zros.Subscriber('chatter', 'std_msgs/msg/String', callback=got.append)
        polled = zros.Subscriber('chatter', 'std_msgs/msg/String')
        pub = zros.Publisher('chatter', 'std_msgs/msg/String')
        pub.wait_for_subscribers(5)
        pub.write(zros.Message('std_msgs/msg/String', data='bye'))
        polled.wait_for_message(5)
        zros.spin_once(1)
        other = zros.Node('second')
        other.create_subscription('std_msgs/msg/String', 'other', lambda m: None)
        print('done', len(got), flush=True)
        # no zros.shutdown(), no node.destroy()
        """,
        zros_router,
    )
    out, err = script.communicate(timeout=30)
    assert script.returncode == 0, err
    assert out.strip() == 'done 1'


def test_ctrl_c_makes_ok_false_and_the_loop_ends_cleanly(zros_router: Router) -> None:
    script = launch(
        """
        import zros
        zros.init('looper')
        zros.Subscriber('chatter', 'std_msgs/msg/String', callback=print)
        print('ready', flush=True)
        loops = 0
        while zros.ok():
            zros.spin_once(1.0)
            loops += 1
        print('stopped after Ctrl-C', flush=True)
        zros.shutdown()
        """,
        zros_router,
    )
    assert script.stdout is not None
    assert script.stdout.readline().strip() == 'ready'
    started = time.monotonic()
    script.send_signal(signal.SIGINT)
    out, err = script.communicate(timeout=30)
    assert script.returncode == 0, err
    assert 'stopped after Ctrl-C' in out
    assert time.monotonic() - started < 2.0  # the waiting spin_once woke up at once


def test_a_second_ctrl_c_interrupts(zros_router: Router) -> None:
    script = launch(
        """
        import time, zros
        zros.init('stubborn')
        print('ready', flush=True)
        while True:          # ignores ok(): the second Ctrl-C must still stop it
            time.sleep(0.05)
        """,
        zros_router,
    )
    assert script.stdout is not None
    assert script.stdout.readline().strip() == 'ready'
    script.send_signal(signal.SIGINT)
    assert wait_for(lambda: script.poll() is not None, timeout=0.5) is False
    script.send_signal(signal.SIGINT)
    _, err = script.communicate(timeout=30)
    assert script.returncode != 0 and 'KeyboardInterrupt' in err


def test_no_router_is_a_clear_error_not_a_hang() -> None:
    env = {**os.environ, 'ZROS_CONNECT': 'tcp/127.0.0.1:1'}
    started = time.monotonic()
    result = subprocess.run(
        [sys.executable, '-c', 'import zros; zros.init("lonely")'],
        env=env,
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert time.monotonic() - started < 10
    assert result.returncode != 0
    assert 'cannot reach a Zenoh router or bridge at tcp/127.0.0.1:1' in result.stderr
    assert "pass connect='tcp/<host>:7447'" in result.stderr  # a program's error names arguments
    assert zros  # the module is importable without a router


def test_a_goal_still_running_when_the_script_ends_gets_to_finish(zros_router: Router) -> None:
    """The exit hook waits (up to 5 s) for an action goal's thread: it replies and publishes the
    goal's status once the callback returns, and a thread stopped inside Zenoh's Rust code as
    the interpreter finalizes aborts the process ('FATAL: exception not rethrown')."""
    script = launch(
        """
        import threading, time, zros
        zros.init('leaving')
        started, release = threading.Event(), threading.Event()

        def execute(goal):
            started.set()
            release.wait(30)
            deadline = time.monotonic() + 1.0
            while time.monotonic() < deadline:  # the last second of the goal's work
                pass
            print('goal finished', flush=True)
            return goal.server.Result()

        zros.ActionServer('work', 'example_interfaces/action/Fibonacci', execute)
        client = zros.ActionClient('work', 'example_interfaces/action/Fibonacci')
        assert client.wait_for_server(10)
        client.send_goal_async(order=1)
        assert started.wait(30)
        print('leaving', flush=True)
        release.set()
        # the script ends while the goal works
        """,
        zros_router,
    )
    out, err = script.communicate(timeout=60)
    assert script.returncode == 0, err
    assert out.splitlines() == ['leaving', 'goal finished'], (out, err)
    assert 'FATAL' not in err
