"""Ctrl-C ends the long-running commands at once, as ros2's do: the measuring verbs exit 0,
``action send_goal`` cancels its goal first and exits 130. SIGTERM (``docker stop``, systemd)
ends them as Ctrl-C does."""

from __future__ import annotations

import signal
import threading
import time
from typing import Any

import pytest

from tests.cli.conftest import Cli, Running, publishing
from tests.support.processes import sleeping
from zros.actions import ServerGoalHandle
from zros.testing import spinning, wait_for

FIB = 'example_interfaces/action/Fibonacci'
#: how soon after SIGINT a command must have ended (1 s asked; the margin is for a loaded machine)
REACTION = 3.0


def interrupted(running: Running, sig: int = signal.SIGINT) -> tuple[int, str, float]:
    """Send ``sig`` once the command waits; the exit code, the output left and the seconds the
    command took to end."""
    assert wait_for(lambda: sleeping(running.process.pid), 10)
    started = time.monotonic()
    running.process.send_signal(sig)
    code, rest = running.finish(timeout=REACTION)
    return code, rest, time.monotonic() - started


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
@pytest.mark.parametrize(
    ('verb', 'report'),
    # the last line of a report: the signal comes while the command waits for the next one
    [('hz', ' window: '), ('bw', 'Message size mean: '), ('delay', ' window: ')],
)
def test_measuring_verbs_end_on_ctrl_c(
    cli: Cli, zros_node: Any, verb: str, report: str, sig: int
) -> None:
    talker = zros_node('talker')
    publisher = talker.create_publisher('geometry_msgs/msg/PointStamped', '/point')
    message = publisher.msg_type()
    message.header.stamp = talker.now().to_msg()
    with publishing(talker, publisher, message, hz=5.0):
        running = cli.start('topic', verb, '/point', '--period', '0.3')
        running.wait_line(lambda line: report in line)
        code, _, took = interrupted(running, sig)
    assert code == 0, running.errors.text()
    assert took < REACTION
    assert 'Traceback' not in running.errors.text()


def test_send_goal_cancels_its_goal_on_ctrl_c(cli: Cli, zros_node: Any) -> None:
    canceled = threading.Event()

    def slow(goal: ServerGoalHandle) -> Any:
        for step in range(600):  # a feedback every 0.1 s for a minute, until the cancel
            goal.publish_feedback(sequence=[step])
            if wait_for(lambda: goal.is_cancel_requested, 0.1):
                goal.canceled()
                canceled.set()
                break
        return goal.server.Result(sequence=[])

    server = zros_node('slow_server')
    server.create_action_server(FIB, '/slow', slow)
    with spinning(server):
        running = cli.start('action', 'send_goal', '/slow', FIB, '{order: 5}', '--feedback')
        running.wait_line(lambda line: line.startswith('Goal accepted with ID: '))
        running.wait_line(lambda line: line == 'Feedback:')
        code, rest, took = interrupted(running)
        assert canceled.wait(10)
    assert code == 130, running.errors.text()
    assert took < REACTION
    assert rest.endswith('Canceling goal...\nGoal canceled.')
    assert 'Result:' not in rest


@pytest.mark.parametrize(
    ('command', 'banner'),
    [
        (('rosbridge', '--port', '0'), 'rosbridge: '),
        (('foxglove', '--port', '0', '--no-sim-time'), 'Foxglove: '),
        (('topic', 'echo', '/point', '--field', 'point'), 'x: '),
    ],
    ids=['rosbridge', 'foxglove', 'echo'],
)
def test_sigterm_ends_a_command_as_ctrl_c(
    cli: Cli, zros_node: Any, command: tuple[str, ...], banner: str
) -> None:
    """``docker stop`` and systemd send SIGTERM: the command closes what it holds and exits 0,
    as on Ctrl-C, instead of dying by the signal (143)."""
    if command[0] == 'foxglove':
        pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')
    talker = zros_node('talker')
    publisher = talker.create_publisher('geometry_msgs/msg/PointStamped', '/point')
    message = publisher.msg_type()
    with publishing(talker, publisher, message, hz=5.0):
        running = cli.start(*command)
        running.wait_line(lambda line: line.startswith(banner) or banner in line)
        code, _, took = interrupted(running, signal.SIGTERM)
    assert code == 0, running.errors.text()
    assert took < REACTION
    assert 'Traceback' not in running.errors.text()


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_echo_with_a_type_waits_for_a_publisher_that_comes_later(
    cli: Cli, zros_node: Any, sig: int
) -> None:
    # as ros2 topic echo /x std_msgs/msg/String: started before anyone publishes, it waits
    running = cli.start('topic', 'echo', '/later', 'std_msgs/msg/String')
    assert wait_for(lambda: sleeping(running.process.pid), 10)
    assert running.process.poll() is None, running.errors.text()
    talker = zros_node('late_talker')
    publisher = talker.create_publisher('std_msgs/msg/String', '/later')
    with publishing(talker, publisher, publisher.msg_type(data='late hello'), hz=5.0):
        running.wait_line(lambda line: line == 'data: late hello')
        code, _, took = interrupted(running, sig)
    assert code == 0, running.errors.text()
    assert took < REACTION
    assert 'Traceback' not in running.errors.text()
