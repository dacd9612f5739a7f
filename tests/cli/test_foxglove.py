"""``zros foxglove``: the command serves the graph (or a bag) until Ctrl-C."""

from __future__ import annotations

import re
import signal
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import zros
from tests.cli.conftest import Cli
from tests.gateway.foxglove_client import FoxgloveClient, require

pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

TIMEOUT = 60.0


@pytest.fixture
def node_client() -> Iterator[list[FoxgloveClient]]:
    require()
    made: list[FoxgloveClient] = []
    yield made
    for client in made:
        client.close()


def _url(line: str) -> str:
    found = re.search(r'wss?://\S+', line)
    assert found is not None, line
    return found.group(0)


def test_the_command_serves_the_graph(
    cli: Cli, zros_node: Any, node_client: list[FoxgloveClient]
) -> None:
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/String', '/chatter')
    running = cli.start('foxglove', '--port', '0', '--no-sim-time', '--topics', '/chat.*')
    url = _url(running.wait_line(lambda line: line.startswith('Foxglove: ')))
    assert url.startswith('ws://127.0.0.1:')
    client = FoxgloveClient(url)
    node_client.append(client)
    subscription = client.subscribe('/chatter', TIMEOUT)
    assert pub.wait_for_subscribers(TIMEOUT)
    message = zros.Message('std_msgs/msg/String', data='through the command')
    pub.write(message)
    assert client.wait_messages(subscription, 1, TIMEOUT) == [message.serialize()]
    assert set(client.channels()) == {'/chatter'}
    running.process.send_signal(signal.SIGINT)
    code, _ = running.finish()
    assert code == 0


def test_the_command_serves_a_bag(
    cli: Cli, testdata: Path, node_client: list[FoxgloveClient]
) -> None:
    bag = testdata / 'ros2' / 'talker_mcap'
    running = cli.start('foxglove', '--port', '0', '--bag', str(bag))
    client = FoxgloveClient(_url(running.wait_line(lambda line: str(bag) in line)))
    node_client.append(client)
    assert 'playbackControl' in client.server_info()['capabilities']
    assert client.channel('/topic', TIMEOUT)['schemaName'] == 'std_msgs/msg/String'
    running.process.send_signal(signal.SIGINT)
    assert running.finish()[0] == 0


@pytest.mark.parametrize(
    ('args', 'error'),
    [
        (['--topics', '('], 'not a valid regex'),
        (
            ['--tls-cert', '/nonexistent.pem', '--tls-key', '/nonexistent.key'],
            'certificate /nonexistent.pem does not exist',
        ),
        (['--bag', '/nonexistent/bag'], 'nonexistent'),
    ],
)
def test_bad_arguments_fail_with_a_message(cli: Cli, args: list[str], error: str) -> None:
    result = cli.run('foxglove', '--port', '0', '--no-sim-time', *args)
    assert result.returncode == 1
    assert error in result.stderr
    assert 'Traceback' not in result.stderr
