"""The ros2 CLI options a ROS 2 user reaches for first: QoS, counts, hidden names, proto."""

from __future__ import annotations

import ast
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

import zros
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
    latched = cli.start('topic', 'pub', '/qos3', 'std_msgs/msg/Int32', '{data: 1}', '--latched',
                        '--qos-profile', 'sensor_data')  # fmt: skip
    assert wait_for(lambda: _endpoint_qos(observer, '/qos3', True) is not None, 30)
    assert _endpoint_qos(observer, '/qos3', True) == QoS(
        5, Reliability.BEST_EFFORT, Durability.TRANSIENT_LOCAL
    )
    latched.process.terminate()
    latched.finish()


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

    # under heavy load a `node list` has been seen to miss every node (before -a, too)
    assert wait_for(lambda: '/lister' in lines('node', 'list'), 30)
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


@pytest.fixture
def counter(zros_node: Node) -> Iterator[Callable[[str], None]]:
    """``start(wire)``: a node on that wire publishing Int32 0, 1, 2... on /count at 50 Hz."""
    stop = threading.Event()
    threads: list[threading.Thread] = []

    def start(wire: str) -> None:
        node = zros_node('counter', wire=wire)
        publisher = node.create_publisher('std_msgs/msg/Int32', '/count', 10)

        def loop() -> None:
            rate = node.create_rate(50)
            number = 0
            while not stop.is_set():
                publisher.write(zros.Message('std_msgs/msg/Int32', data=number))
                number += 1
                rate.sleep()

        threads.append(threading.Thread(target=loop, daemon=True))
        threads[-1].start()

    yield start
    stop.set()
    for thread in threads:
        thread.join(5)


def test_echo_filter_evaluates_an_expression_on_m_like_ros2(
    cli: Cli, counter: Callable[[str], None]
) -> None:
    counter('bridge')
    odd = cli.run('topic', 'echo', '/count', '--count', '3', '--filter', 'm.data % 2 == 1')
    assert odd.returncode == 0, odd.stderr
    numbers = [int(line.split(': ')[1]) for line in odd.stdout.splitlines() if line != '---']
    assert len(numbers) == 3 and all(n % 2 == 1 for n in numbers)
    # on the field --field selects, as ros2
    field = cli.run('topic', 'echo', '/count', '--once', '--field', 'data', '--filter', 'm > 10')
    assert field.returncode == 0, field.stderr
    assert int(field.stdout.splitlines()[0]) > 10


@pytest.mark.parametrize('wire', ['bridge', 'rmw_zenoh'])
def test_echo_raw_and_message_info_like_ros2(
    cli: Cli, counter: Callable[[str], None], wire: str
) -> None:
    counter(wire)
    env = {'ZROS_WIRE': wire}
    raw = cli.run('topic', 'echo', '/count', '--raw', '--once', env=env)
    assert raw.returncode == 0, raw.stderr
    data, end = raw.stdout.splitlines()
    assert end == '---'
    payload = ast.literal_eval(data)  # the bytes' repr, as ros2 prints them
    assert payload[:4] == b'\x00\x01\x00\x00' and len(payload) == 8  # CDR LE header, an int32

    before = time.time_ns()
    info = cli.run('topic', 'echo', '/count', '--once', '-i', env=env)
    assert info.returncode == 0, info.stderr
    lines = info.stdout.splitlines()
    assert [line.split(':')[0] for line in lines[:5]] == [
        'publication_sequence_number',
        'received_timestamp',
        'reception_sequence_number',
        'source_timestamp',
        '---',
    ]
    values = {line.split(': ')[0]: int(line.split(': ')[1]) for line in lines[:4]}
    assert before < values['source_timestamp'] <= values['received_timestamp'] < time.time_ns()
    assert values['reception_sequence_number'] == 1
    # rmw_zenoh's attachment numbers the publisher's messages; the bridge's keys carry none
    assert (values['publication_sequence_number'] > 0) == (wire == 'rmw_zenoh')
    assert lines[5].startswith('data: ') and lines[6] == '---'

    csv = cli.run('topic', 'echo', '/count', '--once', '-i', '--csv', env=env)
    fields = csv.stdout.strip().split(',')
    assert len(fields) == 5 and fields[3] == '1'
    both = cli.run('topic', 'echo', '/count', '--once', '-i', '--raw', env=env).stdout
    head, shown, data_title = both.splitlines()[:3]
    assert head == '---Got new message, message info:---'
    assert list(ast.literal_eval(shown)) == [
        'source_timestamp',
        'received_timestamp',
        'publication_sequence_number',
        'reception_sequence_number',
    ]
    assert data_title == '---Message data:---'


@pytest.mark.parametrize(
    ('args', 'code', 'error'),
    [
        (['--filter', 'm.data >'], 2, "--filter 'm.data >' is not a Python expression"),
        (['--filter', 'm.nope'], 1, "--filter 'm.nope' failed on a message: AttributeError"),
        (['--raw', '--field', 'data'], 2, '--raw prints the whole message as bytes: no --field'),
        (['-i', '--max-age', '1'], 2, '--max-age does not combine with --raw or --include-'),
    ],
)
def test_echo_refuses_what_it_cannot_do(
    cli: Cli, counter: Callable[[str], None], args: list[str], code: int, error: str
) -> None:
    counter('bridge')
    result = cli.run('topic', 'echo', '/count', '--once', *args)
    assert result.returncode == code
    assert error in result.stderr
