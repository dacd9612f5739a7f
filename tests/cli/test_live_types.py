"""Types zros does not ship, met on a live topic: the CLI learns them from the network.

A bag carries its own definitions; ``zros bag play`` serves them on ``~/get_type_description``
(as ROS 2 nodes serve their types) and ``zros topic echo`` asks for a type it cannot resolve.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.cli.conftest import Cli, publishing
from zros.bag import BagTopic, BagWriter
from zros.cdr import encode
from zros.cdr.registry import TypeRegistry
from zros.qos import QoS
from zros.testing import MakeNode

READING = 'zros_test_msgs/msg/Reading'
STATUS = 'my_robot_msgs/msg/Status'
READING_TEXT = """\
# One reading of a sensor zros has never heard of.
uint8 OK=0
uint8 status      # OK, or an error code
float64 value     # metres
string label
"""


def custom_bag(folder: Path) -> Path:
    """A bag whose one topic, /reading, has a type only the bag defines."""
    registry = TypeRegistry('jazzy', paths=[], ament=False)
    registry.register_text(READING, READING_TEXT)
    Reading = registry.get_class(READING)
    with BagWriter(folder / 'readings') as writer:
        topic = writer.add_topic(BagTopic.from_registry(registry, '/reading', READING, [QoS(10)]))
        for index in range(40):
            message = Reading(status=0, value=0.25 * index, label=f'r{index}')
            writer.write(topic, 1_000_000_000 + index * 50_000_000, encode(message))
    return writer.path


@pytest.mark.parametrize('wire', ['bridge', 'rmw_zenoh'])
def test_echo_prints_a_type_only_the_playing_bag_defines(
    cli: Cli, tmp_path: Path, wire: str
) -> None:
    bag = custom_bag(tmp_path)
    player = cli.start('bag', 'play', str(bag), '--loop', '--wire', wire)
    player.wait_line(lambda line: line.startswith('Playing'))
    echo = cli.run('topic', 'echo', '/reading', '--once', '--wire', wire)
    assert echo.returncode == 0, echo.stderr
    lines = echo.stdout.splitlines()
    assert lines[0] == 'status: 0' and lines[1].startswith('value: ')
    assert lines[2].startswith('label: r') and lines[3] == '---'
    player.process.terminate()


def reading_definitions(folder: Path) -> Path:
    """A folder for ZROS_INTERFACE_PATH with ``Reading.msg``."""
    definitions = folder / 'defs'
    (definitions / 'zros_test_msgs' / 'msg').mkdir(parents=True)
    (definitions / 'zros_test_msgs' / 'msg' / 'Reading.msg').write_text(READING_TEXT)
    return definitions


def test_echo_prints_a_custom_type_a_zros_node_publishes(cli: Cli, zros_node: MakeNode) -> None:
    # the user's report: a type registered at run time, published by a plain zros node
    registry = TypeRegistry('jazzy', paths=[], ament=False)
    registry.register_text(STATUS, 'string mode\nfloat64 battery\nint32[] errors\n')
    node = zros_node('custom_pub', registry=registry)
    publisher = node.create_publisher(STATUS, '/status', 10)
    status = registry.get_class(STATUS)(mode='auto', battery=0.5, errors=[1])
    with publishing(node, publisher, status):
        echo = cli.run('topic', 'echo', '/status', '--once')
    assert echo.returncode == 0, echo.stderr
    assert echo.stdout.splitlines() == ['mode: auto', 'battery: 0.5', 'errors:', '- 1', '---']


def test_echo_learns_a_type_the_publisher_found_in_files(cli: Cli, tmp_path: Path) -> None:
    definitions = reading_definitions(tmp_path)
    publisher = cli.start(
        'topic', 'pub', '/reading', READING, '{value: 1.5}', '-r', '20',
        env={'ZROS_INTERFACE_PATH': str(definitions)},
    )  # fmt: skip
    publisher.wait_line(lambda line: line.startswith('publishing #1'))
    echo = cli.run('topic', 'echo', '/reading', '--once')
    assert echo.returncode == 0, echo.stderr
    assert echo.stdout.splitlines()[:2] == ['status: 0', 'value: 1.5']
    publisher.process.terminate()


def test_echo_of_a_type_nobody_describes_says_how_to_add_it(
    cli: Cli, tmp_path: Path, zros_node: MakeNode
) -> None:
    # a publisher whose node does not serve ~/get_type_description
    definitions = reading_definitions(tmp_path)
    registry = TypeRegistry('jazzy', paths=[definitions], ament=False)
    node = zros_node('quiet', registry=registry, start_type_description_service=False)
    publisher = node.create_publisher(READING, '/reading', 10)
    with publishing(node, publisher, registry.get_class(READING)(value=1.5)):
        echo = cli.run('topic', 'echo', '/reading', '--once')
        assert echo.returncode == 1
        assert f"zros: error: unknown ROS type '{READING}'" in echo.stderr
        assert (
            'Add zros_test_msgs/msg/Reading.msg to a folder on ZROS_INTERFACE_PATH' in echo.stderr
        )
        assert 'The nodes on the network did not describe it (/quiet)' in echo.stderr
        # with the definition on ZROS_INTERFACE_PATH, echo needs nobody's help
        found = cli.run(
            'topic', 'echo', '/reading', '--once', env={'ZROS_INTERFACE_PATH': str(definitions)}
        )
    assert found.returncode == 0, found.stderr
    assert found.stdout.splitlines()[:2] == ['status: 0', 'value: 1.5']


def test_the_demo_type_ships_with_zros(cli: Cli) -> None:
    # no registration and no ZROS_INTERFACE_PATH: the .msg inside the package is found
    shown = cli.run('interface', 'show', 'rosR_demos/msg/Linearization')
    assert shown.returncode == 0, shown.stderr
    assert 'float32 dist   # metres' in shown.stdout.splitlines()  # its comments too
    listed = cli.run('interface', 'list', 'rosR_demos')
    assert listed.stdout.split() == ['rosR_demos/msg/Linearization']
