"""``zros node``, ``service`` and ``action`` run as a user runs them."""

from __future__ import annotations

import signal
from collections.abc import Callable
from typing import Any

from tests.cli.conftest import Cli
from zros.actions import ServerGoalHandle
from zros.testing import spinning

Node = Callable[..., Any]
ADD = 'example_interfaces/srv/AddTwoInts'
FIB = 'example_interfaces/action/Fibonacci'


def test_node_list_and_info(cli: Cli, zros_node: Node) -> None:
    driver = zros_node('driver', '/robot')
    driver.create_publisher('std_msgs/msg/String', 'status', 10)
    driver.create_subscription('geometry_msgs/msg/Twist', 'cmd_vel', lambda m: None)
    driver.create_service(ADD, 'add', lambda r: None)
    zros_node('planner')

    listing = cli.run('node', 'list')
    assert listing.returncode == 0, listing.stderr
    assert listing.stdout.split() == ['/planner', '/robot/driver']  # not the command's own node
    assert cli.run('node', 'list', '-c').stdout == '2\n'

    info = cli.run('node', 'info', '/robot/driver').stdout.splitlines()
    assert info[:5] == [
        '/robot/driver',
        '  Subscribers:',
        '    /robot/cmd_vel: geometry_msgs/msg/Twist',
        '  Publishers:',
        '    /parameter_events: rcl_interfaces/msg/ParameterEvent',
    ]
    assert '    /robot/status: std_msgs/msg/String' in info
    servers = info[info.index('  Service Servers:') + 1 : info.index('  Service Clients:')]
    assert '    /robot/add: example_interfaces/srv/AddTwoInts' in servers
    assert '    /robot/driver/get_parameters: rcl_interfaces/srv/GetParameters' in servers
    assert info[-3:] == ['  Service Clients:', '  Action Servers:', '  Action Clients:']
    unknown = cli.run('node', 'info', '/nobody')
    assert unknown.returncode == 1
    assert 'node /nobody does not appear on the network: zros node list shows' in unknown.stderr


def test_node_list_shows_nodes_that_share_a_name_and_warns_once(cli: Cli, zros_node: Node) -> None:
    zros_node('twin')
    zros_node('twin')  # on a session of its own, as a second process would be
    zros_node('single')

    listing = cli.run('node', 'list')
    assert listing.returncode == 0, listing.stderr
    assert listing.stdout.split() == ['/single', '/twin', '/twin']
    assert listing.stderr.count('zros: warning:') == 1
    assert 'some nodes on the network share a full name' in listing.stderr
    counted = cli.run('node', 'list', '-c')
    assert counted.stdout == '3\n'
    assert 'share a full name' in counted.stderr

    info = cli.run('node', 'info', '/twin')
    assert info.returncode == 0, info.stderr
    assert info.stdout.splitlines()[0] == '/twin'
    assert 'zros: warning: 2 nodes on the network are named /twin' in info.stderr
    single = cli.run('node', 'info', '/single')
    assert single.stderr == ''


def test_service_list_type_find_call(cli: Cli, zros_node: Node) -> None:
    server = zros_node('adder', enable_rosout=False, start_parameter_services=False)
    adder = server.create_service(ADD, '/add_two_ints', lambda r: adder.Response(sum=r.a + r.b))
    server.create_service('std_srvs/srv/Trigger', '/ping', lambda r: None)
    assert cli.run('service', 'list').stdout.split() == ['/add_two_ints', '/ping']
    assert cli.run('service', 'list', '-t').stdout.splitlines() == [
        '/add_two_ints [example_interfaces/srv/AddTwoInts]',
        '/ping [std_srvs/srv/Trigger]',
    ]
    assert cli.run('service', 'type', '/ping').stdout == 'std_srvs/srv/Trigger\n'
    assert cli.run('service', 'find', ADD).stdout == '/add_two_ints\n'
    with spinning(server):
        called = cli.run('service', 'call', '/add_two_ints', ADD, '{a: 2, b: 40}')
    assert called.returncode == 0, called.stderr
    # the client may have to wait for the server's route, and then says so first, as ros2 does
    assert called.stdout.removeprefix('waiting for service to become available...\n') == (
        'requester: making request: example_interfaces.srv.AddTwoInts_Request(a=2, b=40)\n\n'
        'response:\nexample_interfaces.srv.AddTwoInts_Response(sum=42)\n\n'
    )


def test_service_call_repeats_at_its_rate_until_ctrl_c(cli: Cli, zros_node: Node) -> None:
    server = zros_node('adder', enable_rosout=False, start_parameter_services=False)
    calls: list[int] = []

    def add(request: Any) -> Any:
        calls.append(request.a)
        return adder.Response(sum=request.a + request.b)

    adder = server.create_service(ADD, '/add_two_ints', add)
    with spinning(server):
        # as ros2's -r: calls at RATE Hz until Ctrl-C, which ends it as echo's (0)
        running = cli.start('service', 'call', '/add_two_ints', ADD, '{a: 2, b: 40}', '-r', '20')
        for _ in range(3):
            running.wait_line(
                lambda line: line == 'example_interfaces.srv.AddTwoInts_Response(sum=42)'
            )
        running.process.send_signal(signal.SIGINT)
        code, _ = running.finish(10)
        assert code == 0, running.errors.text()
        assert 'Traceback' not in running.errors.text()
        assert len(calls) >= 3
        # --times (zros's own) stops after that many calls
        counted = cli.run(
            'service', 'call', '/add_two_ints', ADD, '{a: 1}', '-r', '50', '--times', '4'
        )
    assert counted.returncode == 0, counted.stderr
    assert counted.stdout.count('response:') == 4


def test_service_call_failures(cli: Cli, zros_node: Node) -> None:
    server = zros_node('failing', enable_rosout=False, start_parameter_services=False)

    def broken(request: Any) -> Any:
        raise RuntimeError('the adder is broken')

    server.create_service(ADD, '/broken', broken)
    with spinning(server):
        failed = cli.run('service', 'call', '/broken', ADD, '{a: 1}')
    assert failed.returncode == 1
    assert 'the adder is broken' in failed.stderr
    absent = cli.run('service', 'call', '/absent', ADD, '{a: 1}', '--wait', '0.3')
    assert absent.returncode == 1
    assert 'no server for /absent [example_interfaces/srv/AddTwoInts] appeared' in absent.stderr
    assert 'waiting for service to become available...' in absent.stdout
    wrong = cli.run('service', 'call', '/broken', 'std_msgs/msg/String')
    assert (wrong.returncode, wrong.stderr) == (
        1,
        'zros: error: std_msgs/msg/String is not a service type\n',
    )


def fibonacci(goal: ServerGoalHandle) -> Any:
    sequence = [0, 1]
    for i in range(1, goal.request.order):
        sequence.append(sequence[i] + sequence[i - 1])
        goal.publish_feedback(sequence=sequence)
    if goal.request.order > 20:
        goal.abort()
    return goal.server.Result(sequence=sequence)


def test_action_list_info_send_goal(cli: Cli, zros_node: Node) -> None:
    server = zros_node('fib_server')
    server.create_action_server(FIB, '/fibonacci', fibonacci)
    assert cli.run('action', 'list').stdout == '/fibonacci\n'
    assert (
        cli.run('action', 'list', '-t').stdout
        == '/fibonacci [example_interfaces/action/Fibonacci]\n'
    )
    assert cli.run('action', 'type', '/fibonacci').stdout == f'{FIB}\n'
    assert cli.run('action', 'info', '/fibonacci').stdout.splitlines() == [
        'Action: /fibonacci',
        'Action clients: 0',
        'Action servers: 1',
        '    /fib_server',
    ]
    with spinning(server):
        sent = cli.run('action', 'send_goal', '/fibonacci', FIB, '{order: 3}', '--feedback')
        aborted = cli.run('action', 'send_goal', '/fibonacci', FIB, '{order: 21}')
    assert sent.returncode == 0, sent.stderr
    lines = sent.stdout.splitlines()
    assert lines[:4] == [
        'Waiting for an action server to become available...',
        'Sending goal:',
        '     order: 3',
        '',
    ]
    assert lines[4].startswith('Goal accepted with ID: ') and len(lines[4]) == 23 + 32
    assert sent.stdout.count('Feedback:\n    sequence:\n') == 2
    assert sent.stdout.endswith(
        'Result:\n    sequence:\n    - 0\n    - 1\n    - 1\n    - 2\n\n'
        'Goal finished with status: SUCCEEDED\n'
    )
    assert aborted.returncode == 1
    assert aborted.stdout.endswith('Goal finished with status: ABORTED\n')
    assert 'Feedback:' not in aborted.stdout
    absent = cli.run('action', 'send_goal', '/nope', FIB, '{order: 1}', '--wait', '0.2')
    assert absent.returncode == 1
    assert 'no server for /nope appeared within 0.2 s' in absent.stderr
