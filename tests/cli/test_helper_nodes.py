"""The nodes ``zros`` commands make for themselves: one naming scheme, ``zros_<command>_<verb>_
<pid>``, and every publisher and subscription of theirs on the graph as any node's (both wires)."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

import zros
from tests.cli.conftest import Cli, publishing
from zros.testing import wait_for

Node = Callable[..., Any]


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def wire(request: pytest.FixtureRequest) -> str:
    """The wire the commands and the test's node speak."""
    return str(request.param)


@pytest.fixture
def chatter(zros_node: Node, wire: str) -> Iterator[None]:
    """A node publishing ``/chatter`` at 50 Hz until the test ends."""
    node = zros_node('talker', wire=wire, enable_rosout=False)
    publisher = node.create_publisher('std_msgs/msg/String', '/chatter', 10)
    with publishing(node, publisher, zros.Message('std_msgs/msg/String', data='hi')):
        yield


def test_helper_nodes_are_named_alike_and_fully_visible(
    cli: Cli, chatter: None, wire: str, tmp_path: Path
) -> None:
    hz = cli.start('topic', 'hz', '/chatter', '--period', '0.5', '--wire', wire)
    hz.wait_line(lambda line: line.startswith('average rate'))
    pub = cli.start('topic', 'pub', '/cmd', 'std_msgs/msg/String', '{data: go}', '--wire', wire)
    pub.wait_line(lambda line: line.startswith('publishing #1'))
    hz_node = f'/zros_topic_hz_{hz.process.pid}'
    pub_node = f'/zros_topic_pub_{pub.process.pid}'

    nodes: list[str] = []

    def listed() -> bool:  # a snapshot: a token on its way shows in the next one
        listing = cli.run('node', 'list', '--wire', wire)
        assert listing.returncode == 0, listing.stderr
        nodes[:] = listing.stdout.split()
        return {hz_node, pub_node} <= set(nodes)

    assert wait_for(listed, 30), nodes
    assert all(re.fullmatch(r'/zros_[a-z_]+_\d+', n) for n in nodes if n.startswith('/zros'))

    shown = cli.run('node', 'info', hz_node, '--wire', wire)
    assert shown.returncode == 0, shown.stderr
    info = shown.stdout.splitlines()
    subscribers = info[info.index('  Subscribers:') + 1 : info.index('  Publishers:')]
    assert subscribers == ['    /chatter: std_msgs/msg/String']
    shown = cli.run('node', 'info', pub_node, '--wire', wire)
    assert shown.returncode == 0, shown.stderr
    assert '    /cmd: std_msgs/msg/String' in shown.stdout.splitlines()

    verbose = cli.run('topic', 'info', '/chatter', '-v', '--wire', wire).stdout
    assert 'Subscription count: 1' in verbose
    assert (
        f'Node name: {hz_node}\nTopic type: std_msgs/msg/String\nEndpoint type: SUBSCRIPTION'
        in (verbose)
    )

    picture = cli.run('graph', '-o', str(tmp_path / 'graph.dot'), '--wire', wire)
    assert picture.returncode == 0, picture.stderr
    dot = (tmp_path / 'graph.dot').read_text()
    assert hz_node in dot and pub_node in dot

    no_parameters = cli.run('param', 'list', pub_node, '--wire', wire, '--timeout', '1')
    assert (no_parameters.returncode, no_parameters.stderr) == (
        1,
        f'zros: error: node {pub_node} serves no parameters (it has no parameter services)\n',
    )
    nobody = cli.run('param', 'list', '/nobody', '--wire', wire, '--timeout', '1')
    assert nobody.returncode == 1
    assert 'node /nobody does not appear on the network' in nobody.stderr


def test_hz_of_a_type_without_definition_measures_unannounced(
    cli: Cli, zros_node: Node, wire: str
) -> None:
    # a type only this process knows: the command finds its name on the graph, no definition
    zros.register_type('zros_cli_test_msgs/msg/Probe', 'int32 n')
    node = zros_node('prober', wire=wire, enable_rosout=False)
    publisher = node.create_publisher('zros_cli_test_msgs/msg/Probe', '/probe', 10)
    message = zros.Message('zros_cli_test_msgs/msg/Probe', n=7)
    with publishing(node, publisher, message):
        hz = cli.start('topic', 'hz', '/probe', '--period', '0.5', '--count', '1', '--wire', wire)
        hz.wait_line(lambda line: line.startswith('average rate'))
        code, _ = hz.finish()
    assert code == 0
    assert 'no definition of zros_cli_test_msgs/msg/Probe' in hz.errors.text()
