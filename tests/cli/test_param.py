"""``zros param`` run as a user runs it, against a zros node's parameter services."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tests.cli.conftest import Cli

Node = Callable[..., Any]


@pytest.fixture
def driver(zros_node: Node) -> Any:
    node = zros_node('driver', '/robot', enable_rosout=False)
    node.declare_parameter('speed', 1.5, floating_point_range=(0.0, 3.0, 0.0))
    node.declare_parameter('wheels', 4, read_only=True, description='how many wheels')
    node.declare_parameter('name', 'r2', dynamic_typing=True)
    node.declare_parameter('gains', [1, 2, 3])
    node.declare_parameter('camera.enabled', True)
    return node


def test_list_and_get(cli: Cli, driver: Any) -> None:
    listing = cli.run('param', 'list', '/robot/driver')
    assert listing.returncode == 0, listing.stderr
    assert listing.stdout.splitlines() == [
        '  camera.enabled',
        '  gains',
        '  name',
        '  speed',
        '  use_sim_time',
        '  wheels',
    ]
    typed = cli.run('param', 'list', '/robot/driver', '--param-type').stdout.splitlines()
    assert '  gains (type: integer_array)' in typed
    everyone = cli.run('param', 'list').stdout.splitlines()
    assert everyone[0] == '/robot/driver:'
    assert '  speed' in everyone
    for name, expected in (
        ('speed', 'Double value is: 1.5'),
        ('wheels', 'Integer value is: 4'),
        ('name', 'String value is: r2'),
        ('gains', 'Integer values are: [1, 2, 3]'),
        ('camera.enabled', 'Boolean value is: True'),
    ):
        assert cli.run('param', 'get', '/robot/driver', name).stdout == expected + '\n'
    assert cli.run('param', 'get', '/robot/driver', 'speed', '--hide-type').stdout == '1.5\n'
    missing = cli.run('param', 'get', '/robot/driver', 'nope')
    assert (missing.returncode, missing.stderr) == (
        1,
        'zros: error: parameter nope not set on /robot/driver\n',
    )


def test_set_changes_the_node_parameter(cli: Cli, driver: Any) -> None:
    result = cli.run('param', 'set', '/robot/driver', 'speed', '2.25')
    assert (result.returncode, result.stdout) == (0, 'Set parameter successful\n')
    assert driver.get_parameter('speed') == 2.25
    assert cli.run('param', 'set', '/robot/driver', 'gains', '[4, 5]').returncode == 0
    assert driver.get_parameter('gains') == [4, 5]
    for name, value, reason in (
        ('speed', '9.0', 'range'),
        ('wheels', '6', 'read-only'),
        ('speed', 'fast', 'double'),
    ):
        refused = cli.run('param', 'set', '/robot/driver', name, value)
        assert refused.returncode == 1
        assert refused.stdout.startswith('Setting parameter failed: ')
        assert reason in refused.stdout
    assert driver.get_parameter('speed') == 2.25
    deleted = cli.run('param', 'delete', '/robot/driver', 'name')
    assert deleted.stdout == 'Deleted parameter successfully\n'
    assert not driver.has_parameter('name')
    static = cli.run('param', 'delete', '/robot/driver', 'speed')
    assert static.returncode == 1
    assert static.stdout.startswith('Deleting parameter failed: Static parameter')


def test_describe(cli: Cli, driver: Any) -> None:
    result = cli.run('param', 'describe', '/robot/driver', 'wheels', 'speed')
    assert result.stdout.splitlines() == [
        'Parameter name: wheels',
        '  Type: integer',
        '  Description: how many wheels',
        '  Constraints:',
        '    Read only: true',
        'Parameter name: speed',
        '  Type: double',
        '  Constraints:',
        '    Min value: 0.0',
        '    Max value: 3.0',
    ]


def test_dump_and_load(cli: Cli, driver: Any, tmp_path: Path) -> None:
    dumped = cli.run('param', 'dump', '/robot/driver').stdout
    assert dumped.splitlines()[:4] == [
        '/robot/driver:',
        '  ros__parameters:',
        '    camera:',
        '      enabled: true',
    ]
    assert '    gains: [1, 2, 3]\n' in dumped
    assert '    name: "r2"\n' in dumped
    saved = tmp_path / 'driver.yaml'
    assert cli.run('param', 'dump', '/robot/driver', '-o', str(saved)).returncode == 0
    assert saved.read_text() == dumped
    changed = dumped.replace('speed: 1.5', 'speed: 0.5').replace('"r2"', '"c3po"')
    saved.write_text(changed.replace('wheels: 4', 'wheels: 3'))
    loaded = cli.run('param', 'load', '/robot/driver', str(saved))
    assert loaded.returncode == 1  # wheels is read-only
    assert 'Set parameter speed successful' in loaded.stdout
    assert 'Set parameter wheels failed: ' in loaded.stdout
    assert (driver.get_parameter('speed'), driver.get_parameter('name')) == (0.5, 'c3po')
    atomic = cli.run('param', 'load', '/robot/driver', str(saved), '--atomic')
    assert atomic.returncode == 1
    assert atomic.stdout.startswith('Setting parameters failed: ')
    one = tmp_path / 'one.yaml'
    one.write_text('/robot/driver:\n  ros__parameters:\n    speed: 0.7\n')
    single = cli.run('param', 'load', '/robot/driver', str(one), '--atomic')
    assert (single.returncode, single.stdout) == (0, 'Set 1 parameter successfully\n')
    other = tmp_path / 'other.yaml'
    other.write_text('/someone_else:\n  ros__parameters:\n    x: 1\n')
    none = cli.run('param', 'load', '/robot/driver', str(other))
    assert (none.returncode, none.stderr) == (
        1,
        f'zros: error: {other} has no parameters for /robot/driver\n',
    )
    absent = cli.run('param', 'load', '/robot/driver', str(tmp_path / 'missing.yaml'))
    assert absent.returncode == 1
    assert 'missing.yaml' in absent.stderr


def test_use_sim_time_set_and_load_switch_the_clock(cli: Cli, driver: Any, tmp_path: Path) -> None:
    switched = cli.run('param', 'set', '/robot/driver', 'use_sim_time', 'true')
    assert (switched.returncode, switched.stdout) == (0, 'Set parameter successful\n')
    assert driver.use_sim_time and driver.get_parameter('use_sim_time') is True
    saved = tmp_path / 'wall.yaml'
    saved.write_text('/robot/driver:\n  ros__parameters:\n    use_sim_time: false\n')
    loaded = cli.run('param', 'load', '/robot/driver', str(saved))
    assert (loaded.returncode, loaded.stdout) == (0, 'Set parameter use_sim_time successful\n')
    assert not driver.use_sim_time  # what it said it did
    again = cli.run('param', 'load', '/robot/driver', str(saved))  # the same value: no refusal
    assert (again.returncode, again.stdout) == (0, 'Set parameter use_sim_time successful\n')
    assert not driver.use_sim_time


def test_unknown_node(cli: Cli) -> None:
    result = cli.run('param', 'get', '/ghost', 'x', '--timeout', '0.3', '--wait')
    assert (result.returncode, result.stderr) == (
        1,
        'zros: error: node /ghost not found (nothing serves its parameters)\n',
    )
    at_once = cli.run('param', 'get', '/ghost', 'x')
    assert (at_once.returncode, at_once.stderr) == (
        1,
        'zros: error: node /ghost does not appear on the network: zros node list shows them\n',
    )


def test_list_goes_on_past_a_node_that_does_not_answer(
    cli: Cli, zros_node: Node, driver: Any
) -> None:
    # parameter services that never answer: the node never spins (a ROS node stuck in a callback)
    stuck = zros_node('a_stuck', enable_rosout=False, start_parameter_services=False)
    for service in ('get_parameters', 'list_parameters', 'get_parameter_types'):
        kind = ''.join(word.title() for word in service.split('_'))
        stuck.create_service(f'rcl_interfaces/srv/{kind}', f'~/{service}', lambda r: None)
    listing = cli.run('param', 'list', '--timeout', '1')
    # as ros2's: an error for that node on stderr, the others listed, exit 0
    assert listing.returncode == 0, listing.stderr
    assert (
        listing.stderr == 'zros: error: node /a_stuck did not answer list_parameters within 1 s\n'
    )
    lines = listing.stdout.splitlines()
    assert '/a_stuck:' not in lines
    assert lines[0] == '/robot/driver:'
    assert '  speed' in lines
    # a node named on the command line still fails the command
    alone = cli.run('param', 'list', '/a_stuck', '--timeout', '1')
    assert alone.returncode == 1
    assert 'did not answer list_parameters' in alone.stderr


def test_set_reads_the_value_as_ros2_param_set(cli: Cli, zros_node: Node) -> None:
    """YAML 1.1 as PyYAML reads it (``y`` is a string), not rcl's file rules; ``[]`` empties an
    array of the parameter's type; a list of mixed types is the text itself."""
    node = zros_node('lists', '/robot', enable_rosout=False)
    node.declare_parameter('names', ['a'])
    node.declare_parameter('gains', [1.0, 2.0])
    node.declare_parameter('label', 'x')
    for name, text, expected in (
        ('names', '[x, y]', ['x', 'y']),
        ('names', '[n, yes]', None),
        ('gains', '[]', []),
        ('label', '[1, b]', '[1, b]'),
        ('label', '"5"', '5'),
        ('label', '1e3', '1e3'),
    ):
        result = cli.run('param', 'set', '/robot/lists', name, text)
        if expected is None:  # [n, yes] holds a string and a bool: the text, refused as a string
            assert result.returncode == 1
            assert 'string_array' in result.stdout and '-p' not in result.stdout
            continue
        assert (result.returncode, result.stdout) == (0, 'Set parameter successful\n'), text
        assert node.get_parameter(name) == expected


def test_an_integer_for_a_double_is_refused_both_ways(cli: Cli, driver: Any) -> None:
    """ROS's rule on both paths: ``param set`` and the node's own ``set_parameter`` refuse 2 for a
    double and say what to write."""
    refused = cli.run('param', 'set', '/robot/driver', 'speed', '2')
    assert refused.returncode == 1
    assert refused.stdout.endswith('speed is a double: write 2.0\n')
    local = driver.set_parameters({'speed': 2})
    assert not local[0].successful
    assert local[0].reason.endswith('speed is a double: write 2.0')
    assert driver.get_parameter('speed') == 1.5
