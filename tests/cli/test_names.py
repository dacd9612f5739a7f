"""A mistyped name fails once the graph has answered, with the closest known names, instead of
after the whole wait (issue 37, point 5; ``--wait`` still waits); a type other than the one the
graph advertises is refused before anything is sent or printed (point 3)."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zros
from tests.cli.conftest import Cli
from zros.testing import spinning

Node = Callable[..., Any]
ADD = 'example_interfaces/srv/AddTwoInts'
FIB = 'example_interfaces/action/Fibonacci'
#: well under the 5-11 s a typo cost (the graph answers at once on loopback)
FAST = 5.0


def timed(cli: Cli, *args: str) -> tuple[float, int, str]:
    started = time.monotonic()
    result = cli.run(*args)
    return time.monotonic() - started, result.returncode, result.stderr


def test_mistyped_topics_suggest_the_closest(cli: Cli, zros_node: Node) -> None:
    talker = zros_node('talker')
    talker.create_publisher('std_msgs/msg/String', '/chatter', 10)
    for verb in ('echo', 'hz', 'bw', 'info', 'type'):
        elapsed, code, stderr = timed(cli, 'topic', verb, '/chater')
        assert (code, stderr) == (
            1,
            'zros: error: topic /chater does not appear on the network: did you mean /chatter?\n',
        ), verb
        assert elapsed < FAST, verb
    _, code, stderr = timed(cli, 'topic', 'echo', '/nothing_like_it')
    assert code == 1
    assert stderr.endswith(': zros topic list shows them\n')


def test_mistyped_echo_field_suggests_the_closest_at_once(cli: Cli, zros_node: Node) -> None:
    talker = zros_node('talker')
    pose = zros.Message('geometry_msgs/msg/PoseStamped', pose={'position': {'x': 1.0}})
    talker.create_publisher('geometry_msgs/msg/PoseStamped', '/pose', 'latched').write(pose)
    talker.create_publisher('geometry_msgs/msg/PoseStamped', '/quiet', 10)  # sends nothing
    for topic in ('/pose', '/quiet'):  # the field is checked before any message arrives
        elapsed, code, stderr = timed(cli, 'topic', 'echo', topic, '--field', 'pose.positon')
        assert (code, stderr) == (
            1,
            'zros: error: --field pose.positon: geometry_msgs/msg/PoseStamped has no field '
            "'pose.positon' (did you mean 'pose.position'? fields of geometry_msgs/msg/Pose: "
            'position, orientation)\n',
        ), topic
        assert elapsed < FAST, topic
    _, code, stderr = timed(cli, 'topic', 'echo', '/quiet', '--field', 'header.stamp.sec.x')
    assert (code, stderr) == (
        1,
        "zros: error: --field header.stamp.sec.x: 'x' is not a field of int\n",
    )
    right = cli.run('topic', 'echo', '/pose', '--once', '--field', 'pose.position.x')
    assert right.stdout == '1.0\n---\n'


def test_wait_keeps_waiting_for_the_topic(cli: Cli) -> None:
    elapsed, code, stderr = timed(cli, 'topic', 'echo', '/chater', '--wait', '1.5')
    assert code == 1
    assert 'did you mean' not in stderr
    assert elapsed >= 1.5


def test_mistyped_service_and_action(cli: Cli, zros_node: Node) -> None:
    server = zros_node('server', enable_rosout=False, start_parameter_services=False)
    server.create_service(ADD, '/add_two_ints', lambda request, response: response)
    server.create_action_server(FIB, '/fibonacci', lambda goal: None)
    with spinning(server):
        elapsed, code, stderr = timed(cli, 'service', 'call', '/add_two_int', ADD, '{a: 1}')
        assert (code, stderr) == (
            1,
            'zros: error: service /add_two_int does not appear on the network: '
            'did you mean /add_two_ints?\n',
        )
        assert elapsed < FAST
        elapsed, code, stderr = timed(cli, 'action', 'send_goal', '/fibonaci', FIB, '{order: 2}')
        assert (code, stderr) == (
            1,
            'zros: error: action /fibonaci does not appear on the network: '
            'did you mean /fibonacci?\n',
        )
        assert elapsed < FAST
        waited = cli.run('service', 'call', '/add_two_int', ADD, '--wait', '0.3')
        assert 'no server for /add_two_int' in waited.stderr


def test_mistyped_node_and_parameter(cli: Cli, zros_node: Node) -> None:
    talker = zros_node('talker')
    talker.declare_parameter('publish_rate', 2.0)
    with spinning(talker):
        for args in (('param', 'get', '/talkr', 'publish_rate'), ('node', 'info', '/talkr')):
            elapsed, code, stderr = timed(cli, *args)
            assert (code, stderr) == (
                1,
                'zros: error: node /talkr does not appear on the network: did you mean /talker?\n',
            ), args
            assert elapsed < FAST
        _, code, stderr = timed(cli, 'param', 'get', '/talker', 'publish_rat')
        assert (code, stderr) == (
            1,
            'zros: error: parameter publish_rat not set on /talker: did you mean publish_rate?\n',
        )
        refused = cli.run('param', 'set', '/talker', 'publish_rat', '3.0')
        assert refused.returncode == 1
        assert refused.stdout.startswith('Setting parameter failed: ')
        assert refused.stdout.endswith(': did you mean publish_rate?\n')
        waited = cli.run('param', 'get', '/talkr', 'x', '--wait', '--timeout', '0.3')
        assert 'node /talkr not found' in waited.stderr


def test_a_type_the_graph_contradicts_is_refused(cli: Cli, zros_node: Node, tmp_path: Path) -> None:
    """Issue 37, point 3: nothing is sent or printed with a type other than the advertised one."""
    talker = zros_node('talker', enable_rosout=False, start_parameter_services=False)
    talker.create_publisher('std_msgs/msg/String', '/chatter', 10)
    heard: list[Any] = []
    talker.create_subscription('std_msgs/msg/String', '/chatter', heard.append)
    talker.create_service(ADD, '/add_two_ints', lambda request, response: response)
    talker.create_action_server(FIB, '/fibonacci', lambda goal: None)
    refused = 'zros: error: /chatter carries std_msgs/msg/String, not std_msgs/msg/Int32\n'
    with spinning(talker):
        for args in (
            ('topic', 'echo', '/chatter', 'std_msgs/msg/Int32'),
            ('topic', 'echo', '/chatter', 'std_msgs/Int32'),
            ('topic', 'delay', '/chatter', 'std_msgs/msg/Int32'),
            ('topic', 'pub', '/chatter', 'std_msgs/msg/Int32', '{data: 1}', '--once'),
        ):
            result = cli.run(*args)
            assert (result.returncode, result.stdout, result.stderr) == (1, '', refused), args
        call = cli.run('service', 'call', '/add_two_ints', 'std_srvs/srv/Trigger')
        assert (call.returncode, call.stdout, call.stderr) == (
            1,
            '',
            'zros: error: /add_two_ints carries example_interfaces/srv/AddTwoInts, '
            'not std_srvs/srv/Trigger\n',
        )
        # an action type of our own, to send to the Fibonacci server
        (tmp_path / 'zros_test_msgs' / 'action').mkdir(parents=True)
        text = 'int32 steps\n---\nbool done\n---\nint32 left\n'
        (tmp_path / 'zros_test_msgs' / 'action' / 'Count.action').write_text(text)
        goal = cli.run(
            'action', 'send_goal', '/fibonacci', 'zros_test_msgs/action/Count', '{steps: 1}',
            env={'ZROS_INTERFACE_PATH': str(tmp_path)},
        )  # fmt: skip
        assert (goal.returncode, goal.stdout) == (1, '')
        assert (
            goal.stderr
            == f'zros: error: /fibonacci carries {FIB}, not zros_test_msgs/action/Count\n'
        )
    assert heard == []
