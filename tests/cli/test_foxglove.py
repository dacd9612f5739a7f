"""``zros foxglove``: the command serves the graph (or a bag) until Ctrl-C."""

from __future__ import annotations

import re
import signal
import socket
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import zros
from tests.cli.conftest import Cli
from tests.gateway.foxglove.client import FoxgloveClient, image
from tests.gateway.node_process import require
from zros.testing import child_processes, wait_for

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


def test_the_command_guards_the_robot(cli: Cli, node_client: list[FoxgloveClient]) -> None:
    """``--read-only``: clients may not publish or call; ``--allow-origin``: pages of that
    site connect, pages of others get 403 (and the log says which option would allow them)."""
    running = cli.start(
        'foxglove', '--port', '0', '--no-sim-time', '--read-only',
        '--allow-origin', 'https://viewer.example',
    )  # fmt: skip
    line = running.wait_line(lambda line: line.startswith('Foxglove: '))
    assert 'read-only' in line
    url = _url(line)
    viewer = FoxgloveClient(url, origin='https://viewer.example')
    app = FoxgloveClient(url, origin='https://app.foxglove.dev')  # allowed by default
    evil = FoxgloveClient(url, origin='https://evil.example')
    node_client += [viewer, app, evil]
    capabilities = set(viewer.server_info()['capabilities'])
    assert not capabilities & {'clientPublish', 'services'}
    assert app.server_info()['name'] == 'zros'
    assert evil.wait(lambda e: e['ev'] == 'refused')['status'] == 403
    running.process.send_signal(signal.SIGINT)
    assert running.finish()[0] == 0
    assert '--allow-origin https://evil.example' in running.errors.text()


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


def _rss(pid: int) -> int:
    """The resident memory of a process and its children (the front's process), in bytes."""
    total = 0
    for process in [pid, *child_processes(pid)]:
        for line in Path(f'/proc/{process}/status').read_text().splitlines():
            if line.startswith('VmRSS:'):
                total += int(line.split()[1]) * 1024
    return total


#: seconds of camera stream (issue 33 asks 60: at this rate the SDK's outbox, bounded in
#: messages, had grown by 4 GB in 20 s; a bound in bytes shows in a few seconds already)
STREAM_SECONDS = 20.0


def test_a_client_that_does_not_read_costs_at_most_its_buffer(
    cli: Cli, zros_node: Any, node_client: list[FoxgloveClient]
) -> None:
    """A client watching a 1080p rgb8 camera at 30 Hz that never reads: the gateway's memory
    (its front's process included) grows by at most 2 x ``--client-buffer`` + 100 MB, and another client keeps 90 % of
    the frames, in time."""
    if not Path('/proc/self/status').exists():
        pytest.skip('needs /proc to read the memory of a process')
    buffer = 32 * 1024**2
    camera = zros_node('camera')
    pub = camera.create_publisher('sensor_msgs/msg/Image', '/camera')
    running = cli.start(
        'foxglove',
        '--port',
        '0',
        '--no-sim-time',
        '--client-buffer',
        '32MiB',
        '--topics',
        '/camera',
    )
    url = _url(running.wait_line(lambda line: line.startswith('Foxglove: ')))
    slow, fast = FoxgloveClient(url), FoxgloveClient(url)
    node_client += [slow, fast]
    slow.subscribe('/camera', TIMEOUT)
    slow.send('pauseReading')
    subscription = fast.subscribe('/camera', TIMEOUT, quiet=True)
    assert pub.wait_for_subscribers(TIMEOUT)
    frame = image(1920, 1080, 7).serialize()
    before = _rss(running.process.pid)
    peak = before
    sent = 0
    start = time.monotonic()
    while time.monotonic() - start < STREAM_SECONDS:
        pub.write_raw(frame)
        sent += 1
        while time.monotonic() < start + sent / 30.0:  # 30 Hz, watching the memory meanwhile
            peak = max(peak, _rss(running.process.pid))
            time.sleep(0.005)

    def received() -> int:
        return int(fast.stats().get(str(subscription), {}).get('count', 0))

    wait_for(lambda: received() >= sent, 5.0)  # the frames still on their way
    peak = max(peak, _rss(running.process.pid))
    got = received()
    assert peak - before <= 2 * buffer + 100 * 1024**2, (before, peak)
    assert got >= 0.9 * sent, (got, sent)
    running.process.send_signal(signal.SIGINT)
    code, _ = running.finish()
    assert code == 0
    assert 'does not read fast enough' in running.errors.text()


def test_a_killed_gateway_leaves_no_front_behind(cli: Cli) -> None:
    """The front's process ends when the gateway's does, even by SIGKILL: the port is free."""
    if not Path('/proc/self/stat').exists():
        pytest.skip('needs /proc to find the processes')
    running = cli.start('foxglove', '--port', '0', '--no-sim-time')
    url = _url(running.wait_line(lambda line: line.startswith('Foxglove: ')))
    port = int(url.rpartition(':')[2])
    fronts = child_processes(running.process.pid)
    assert len(fronts) == 1
    front = Path(f'/proc/{fronts[0]}/stat')

    def ended() -> bool:  # gone, or a zombie nobody reaps (the parent of orphans may not)
        try:
            return front.read_text().rpartition(')')[2].split()[0] == 'Z'
        except OSError:
            return True

    assert not ended()
    running.process.kill()
    running.finish()
    assert wait_for(ended, TIMEOUT)
    with socket.create_server(('127.0.0.1', port)):  # nobody listens there any more
        pass
