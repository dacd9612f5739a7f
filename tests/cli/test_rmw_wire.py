"""The command line on the rmw_zenoh wire (``--wire rmw_zenoh``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import zros
from tests.cli.conftest import Cli


def test_commands_speak_rmw_zenoh(cli: Cli, zros_node: Callable[..., Any]) -> None:
    node = zros_node('driver', '/robot', wire='rmw_zenoh', enable_rosout=False)
    node.create_publisher('std_msgs/msg/String', 'status', 'latched').write(
        zros.Message('std_msgs/msg/String', data='ready')
    )
    node.create_subscription('geometry_msgs/msg/Twist', 'cmd_vel', lambda m: None)

    listing = cli.run('topic', 'list', '-t', '--wire', 'rmw_zenoh')
    assert listing.returncode == 0, listing.stderr
    assert '/robot/status [std_msgs/msg/String]' in listing.stdout.splitlines()
    info = cli.run('node', 'info', '/robot/driver', '--wire', 'rmw_zenoh').stdout.splitlines()
    assert '    /robot/cmd_vel: geometry_msgs/msg/Twist' in info
    assert '    /robot/status: std_msgs/msg/String' in info
    echo = cli.run('topic', 'echo', '/robot/status', '--once', '--wire', 'rmw_zenoh')
    assert echo.stdout == 'data: ready\n---\n', echo.stderr
    wrong = cli.run('topic', 'list', '--wire', 'dds')
    assert wrong.returncode == 2
    assert "invalid choice: 'dds'" in wrong.stderr


def test_each_scheme_has_its_own_settings(cli: Cli, zros_node: Callable[..., Any]) -> None:
    """``--domain-id`` is rmw_zenoh's: the node it opens lives in that domain, and beside the
    bridge wire it is a usage error naming the scheme that takes it."""
    node = zros_node('far', wire='rmw_zenoh', domain_id=5, enable_rosout=False)
    node.create_publisher('std_msgs/msg/String', '/far', 'latched').write(
        zros.Message('std_msgs/msg/String', data='domain 5')
    )
    echo = cli.run('topic', 'echo', '/far', '--once', '--wire', 'rmw_zenoh', '--domain-id', '5')
    assert echo.stdout == 'data: domain 5\n---\n', echo.stderr
    wrong = cli.run('topic', 'list', '--wire', 'bridge', '--domain-id', '5')
    assert wrong.returncode == 2
    # named as typed: the command's flags, not Node's keywords
    assert '--domain-id is for --wire rmw_zenoh, not --wire bridge' in wrong.stderr
    assert 'domain_id=' not in wrong.stderr
    chosen = cli.run('topic', 'list', '--bridge-namespace', '/x', env={'ZROS_WIRE': 'rmw_zenoh'})
    assert chosen.returncode == 2
    assert '--bridge-namespace is for --wire bridge, not ZROS_WIRE=rmw_zenoh' in chosen.stderr
    bogus = cli.run('topic', 'list', env={'ZROS_WIRE': 'dds'})
    assert bogus.returncode == 2
    assert 'zros: error: ZROS_WIRE must be "bridge" or "rmw_zenoh", got \'dds\'' in bogus.stderr
