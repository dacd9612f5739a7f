"""The ros2 CLI options a ROS 2 user reaches for first: QoS, counts, hidden names, proto."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from tests.cli.conftest import Cli
from tests.cli.test_graph_verbs import fibonacci
from zros.qos import Durability, History, QoS, Reliability
from zros.testing import wait_for

Node = Callable[..., Any]


def _endpoint_qos(node: Any, topic: str, publishers: bool) -> QoS | None:
    key = node.scheme.key(topic)
    ends = (node.graph.publishers if publishers else node.graph.subscribers)(key)
    return ends[0].qos if ends else None


def test_pub_and_echo_take_ros2_qos_options(cli: Cli, zros_node: Node) -> None:
    observer = zros_node('observer')
    pub = cli.start(
        'topic', 'pub', '/qos', 'std_msgs/msg/Int32', '{data: 7}', '-r', '20',
        '--qos-profile', 'sensor_data', '--qos-depth', '3', '--qos-durability', 'transient_local',
    )  # fmt: skip
    assert wait_for(lambda: _endpoint_qos(observer, '/qos', True) is not None, 30)
    assert _endpoint_qos(observer, '/qos', True) == QoS(
        3, Reliability.BEST_EFFORT, Durability.TRANSIENT_LOCAL
    )
    echo = cli.start(
        'topic', 'echo', '/qos', '--qos-history', 'keep_all', '--qos-reliability', 'reliable',
    )  # fmt: skip
    echo.wait_line(lambda line: line == 'data: 7')
    # durability not given: matched to the (transient local) publisher, as ros2's echo does
    assert _endpoint_qos(observer, '/qos', False) == QoS(
        100, Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, History.KEEP_ALL
    )
    for running in (echo, pub):
        running.process.terminate()
        running.finish()
    profile = cli.start('topic', 'echo', '/qos2', 'std_msgs/msg/Int32', '--wait',
                        '--qos-profile', 'parameters')  # fmt: skip
    assert wait_for(lambda: _endpoint_qos(observer, '/qos2', False) is not None, 30)
    assert _endpoint_qos(observer, '/qos2', False) == QoS(1000)
    profile.process.terminate()
    profile.finish()


def test_qos_options_refuse_what_ros2_refuses(cli: Cli) -> None:
    for option, value in (('--qos-profile', 'fast'), ('--qos-depth', '0'),
                          ('--qos-reliability', 'sometimes')):  # fmt: skip
        result = cli.run('topic', 'pub', '/x', 'std_msgs/msg/Int32', '{}', option, value)
        assert result.returncode == 2, result.stderr
        assert option in result.stderr
    keep_all = cli.run(
        'topic', 'pub', '/x', 'std_msgs/msg/Int32', '{}', '-1', '-w', '0',
        '--qos-history', 'keep_all', '--qos-depth', '5',
    )  # fmt: skip
    assert keep_all.returncode == 0, keep_all.stderr


def test_list_and_find_count_and_hide_hidden_names_like_ros2(cli: Cli, zros_node: Node) -> None:
    node = zros_node('lister')
    node.create_publisher('std_msgs/msg/String', '/seen', 10)
    node.create_publisher('std_msgs/msg/String', '/_hidden/chatter', 10)
    node.create_service('std_srvs/srv/Trigger', '/reset', lambda req, res: res)
    node.create_service('std_srvs/srv/Trigger', '/_secret', lambda req, res: res)
    zros_node('_hidden_node')

    def lines(*args: str) -> list[str]:
        result = cli.run(*args)
        assert result.returncode == 0, result.stderr
        return result.stdout.splitlines()

    topics = lines('topic', 'list')
    assert '/seen' in topics and '/_hidden/chatter' not in topics
    every = lines('topic', 'list', '--include-hidden-topics')
    assert '/_hidden/chatter' in every
    assert lines('topic', 'list', '-c') == [str(len(topics))]
    assert lines('topic', 'list', '--count-topics', '--include-hidden-topics') == [str(len(every))]
    assert lines('topic', 'find', 'std_msgs/msg/String') == ['/seen']
    assert lines('topic', 'find', 'std_msgs/msg/String', '-c') == ['1']
    assert lines('topic', 'find', 'std_msgs/msg/String', '-c', '--include-hidden-topics') == ['2']

    services = lines('service', 'list')
    assert '/reset' in services and '/_secret' not in services
    assert '/_secret' in lines('service', 'list', '--include-hidden-services')
    assert lines('service', 'list', '--count-services') == [str(len(services))]
    assert lines('service', 'find', 'std_srvs/srv/Trigger', '-c') == ['1']
    assert lines('service', 'find', 'std_srvs/srv/Trigger', '--include-hidden-services') == [
        '/_secret',
        '/reset',
    ]

    nodes = lines('node', 'list')
    assert '/lister' in nodes and '/_hidden_node' not in nodes
    assert '/_hidden_node' in lines('node', 'list', '-a')
    assert lines('node', 'list', '--all', '-c') == [str(len(nodes) + 1)]


def test_action_list_counts(cli: Cli, zros_node: Node) -> None:
    node = zros_node('actor')
    node.create_action_server('example_interfaces/action/Fibonacci', '/fibonacci', fibonacci)
    node.create_action_server('example_interfaces/action/Fibonacci', '/fib2', fibonacci)
    result = cli.run('action', 'list', '-c')
    assert result.returncode == 0, result.stderr
    assert result.stdout == '2\n'
    assert cli.run('action', 'list', '--count-actions').stdout == '2\n'


def test_interface_proto_prints_the_default_message_as_ros2(cli: Cli) -> None:
    twist = cli.run('interface', 'proto', 'geometry_msgs/msg/Twist')
    assert twist.returncode == 0, twist.stderr
    assert twist.stdout == (
        '"linear:\n  x: 0.0\n  y: 0.0\n  z: 0.0\nangular:\n  x: 0.0\n  y: 0.0\n  z: 0.0\n"\n'
    )
    # a service: its request; an action: its goal; --no-quotes: as ros2, the YAML and a blank line
    assert cli.run('interface', 'proto', 'std_srvs/srv/SetBool', '--no-quotes').stdout == (
        'data: false\n\n'
    )
    assert cli.run('interface', 'proto', 'example_interfaces/action/Fibonacci').stdout == (
        '"order: 0\n"\n'
    )
    assert cli.run('interface', 'proto', 'std_msgs/msg/Empty').stdout == '"{}\n"\n'
    header = cli.run('interface', 'proto', 'std_msgs/msg/Header', '--no-quotes').stdout
    assert header == "stamp:\n  sec: 0\n  nanosec: 0\nframe_id: ''\n\n"
    unknown = cli.run('interface', 'proto', 'nope/msg/X')
    assert unknown.returncode == 1
    assert "unknown ROS type 'nope/msg/X'" in unknown.stderr
