"""``zros bag record`` run as a user runs it: stopped by a signal it finishes the bag; killed,
it leaves files readable up to their last chunk."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.bag.write.test_record import bag_yaml, read_rosbags
from tests.cli.conftest import ZROS, Cli
from tests.support.router_process import RouterProcess, free_endpoint
from zros.bag import Bag
from zros.bag.progress import Progress
from zros.testing import wait_for
from zros.transport import Router

Node = Callable[..., Any]
STRING = 'std_msgs/msg/String'


@pytest.fixture
def zros_cli(zros_router: Router) -> Iterator[Cli]:
    """The ``zros`` console script, connected to the test's router."""
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    commands = Cli(zros_router.endpoint)
    yield commands
    for running in commands.started:
        if running.process.poll() is None:
            running.process.kill()
            running.process.wait(10)


def complete_chunks(file: Path) -> list[tuple[str, bytes]]:
    """(topic, data) of every message in the file's complete chunks: a linear scan that stops
    at the first record cut short, as a recovering reader does."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Message
    from mcap.stream_reader import StreamReader
    from zstandard import ZstdError

    channels: dict[int, str] = {}
    found: list[tuple[str, bytes]] = []
    if not file.exists():
        return found
    with file.open('rb') as stream:
        try:
            for record in StreamReader(stream, validate_crcs=True).records:
                if isinstance(record, Channel):
                    channels[record.id] = record.topic
                elif isinstance(record, Message):
                    found.append((channels[record.channel_id], record.data))
        except (McapError, ZstdError):  # a chunk still being written is cut short
            pass
    return found


def texts(messages: list[tuple[str, bytes]]) -> list[str]:
    from zros.cdr import decode, default_registry

    cls = default_registry().get_class(STRING)
    return [decode(cls, data).data for _, data in messages]


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM])
def test_record_until_stopped_by_a_signal(
    zros_cli: Cli, zros_node: Node, tmp_path: Path, stop: signal.Signals
) -> None:
    folder = tmp_path / 'cli_bag'
    running = zros_cli.start('bag', 'record', '-o', str(folder), '/chatter', '/numbers')
    assert running.wait_line(lambda line: line.startswith('Recording to')).endswith('cli_bag')
    talker = zros_node('talker')
    chatter = talker.create_publisher(STRING, '/chatter')
    numbers = talker.create_publisher('std_msgs/msg/Int32', '/numbers')
    running.wait_line(lambda line: line.startswith('Subscribed to topic /'))
    running.wait_line(lambda line: line.startswith('Subscribed to topic /'))
    assert chatter.wait_for_subscribers() and numbers.wait_for_subscribers()
    for n in range(100):
        chatter.write(chatter.msg_type(data=f'c{n}'))
        numbers.write(numbers.msg_type(data=n))
    # chunks reach the disk at least every second: then every message has arrived
    assert wait_for(lambda: len(complete_chunks(folder / 'cli_bag_0.mcap')) == 200, 20)
    running.process.send_signal(stop)
    code, rest = running.finish()
    assert code == 0, rest
    assert f'Recorded 200 messages on 2 topics into 1 file of {folder}' in rest
    got = read_rosbags(folder)
    assert [m.data for t, _, m in got if t == '/chatter'] == [f'c{n}' for n in range(100)]
    assert [m.data for t, _, m in got if t == '/numbers'] == list(range(100))
    assert bag_yaml(folder)['message_count'] == 200


@pytest.fixture
def busy_cpus() -> Iterator[None]:
    """Every core of the machine kept busy by a spinning process while the test runs."""
    hogs = [
        subprocess.Popen([sys.executable, '-c', 'while True: pass'])
        for _ in range(os.cpu_count() or 2)
    ]
    yield
    for hog in hogs:
        hog.kill()
        hog.wait(10)


def test_record_stops_cleanly_while_every_cpu_is_busy(
    zros_cli: Cli, zros_node: Node, tmp_path: Path, busy_cpus: None
) -> None:
    """A recorder's subscriptions come from its discovery thread, a daemon: their Zenoh
    callback threads were daemons too, and one still waiting for the CPU when the interpreter
    finalized aborted the process (exit -6, 'FATAL: exception not rethrown') after the bag was
    written. The exit now waits for them."""
    for attempt in range(5):  # the abort took one stop in a few
        folder = tmp_path / f'busy_{attempt}'
        running = zros_cli.start('bag', 'record', '-o', str(folder), '/chatter')
        chatter = zros_node(f'talker_{attempt}').create_publisher(STRING, '/chatter')
        running.wait_line(lambda line: line.startswith('Subscribed to topic /'))
        assert chatter.wait_for_subscribers(60)
        for n in range(20):
            chatter.write(chatter.msg_type(data=f'c{n}'))
        file = folder / f'busy_{attempt}_0.mcap'
        assert wait_for(lambda file=file: len(complete_chunks(file)) == 20, 60)
        running.process.send_signal(signal.SIGINT)
        code, rest = running.finish(60)
        assert code == 0, rest
        chatter.close()


def test_a_killed_recorder_leaves_every_complete_chunk_readable(
    zros_cli: Cli, zros_node: Node, tmp_path: Path
) -> None:
    folder = tmp_path / 'killed'
    file = folder / 'killed_0.mcap'
    running = zros_cli.start('bag', 'record', '-o', str(folder), '/burst')
    talker = zros_node('talker')
    publisher = talker.create_publisher(STRING, '/burst', 'keep_all')
    running.wait_line(lambda line: line == 'Subscribed to topic /burst [std_msgs/msg/String]')
    assert publisher.wait_for_subscribers()
    sent = [f'message {n}' for n in range(3000)]
    for text in sent[:1000]:
        publisher.write(publisher.msg_type(data=text))
    assert wait_for(lambda: len(complete_chunks(file)) == 1000, 20)
    for text in sent[1000:]:
        publisher.write(publisher.msg_type(data=text))
    running.process.kill()  # SIGKILL: no chance to finish the file
    running.process.wait(10)
    # the recorder keeps metadata.yaml current: it names the file and the topic
    assert [f['path'] for f in bag_yaml(folder)['files']] == ['killed_0.mcap']
    assert bag_yaml(folder)['topics_with_message_count'][0]['topic_metadata']['name'] == '/burst'
    recovered = texts(complete_chunks(file))
    assert len(recovered) >= 1000
    assert recovered == sent[: len(recovered)]  # in order, nothing missing before the cut
    assert not file.read_bytes().endswith(b'\x89MCAP0\r\n')  # it was never finished


def test_record_refusals(zros_cli: Cli, tmp_path: Path) -> None:
    result = zros_cli.run('bag', 'record', '-o', str(tmp_path / 'x'))
    assert result.returncode == 1
    assert 'nothing to record' in result.stderr
    (tmp_path / 'taken').mkdir()
    result = zros_cli.run('bag', 'record', '-a', '-o', str(tmp_path / 'taken'))
    assert result.returncode == 1
    assert result.stderr.startswith('zros: error: the output folder')
    result = zros_cli.run('bag', 'record', '-a', '--compression', 'bz2')
    assert result.returncode == 2


def test_progress_line_only_on_a_terminal() -> None:
    import io

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    terminal = Terminal()
    progress = Progress(terminal)
    assert progress.enabled
    progress.update('[RECORDING] 1 messages')
    progress.update('[RECORDING] 2 messages')  # within the interval: skipped
    progress.update('[RECORDING] 3 messages', force=True)
    progress.close()
    assert terminal.getvalue() == ('\r[RECORDING] 1 messages\x1b[K\r[RECORDING] 3 messages\x1b[K\n')
    pipe = io.StringIO()
    quiet = Progress(pipe)
    quiet.update('x', force=True)
    quiet.close()
    assert not quiet.enabled and pipe.getvalue() == ''


def test_record_summary_reports_the_router_outages(tmp_path: Path) -> None:
    """Messages published while the link is down are not in the bag: the summary says so, and
    the bag keeps when, for whoever reads it later (``Bag.outages``, ``zros bag info``)."""
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    router = RouterProcess(free_endpoint())
    router.start()
    cli = Cli(router.endpoint)
    folder = tmp_path / 'gap'
    try:
        running = cli.start('bag', 'record', '-o', str(folder), '/chatter')
        running.wait_line(lambda line: line.startswith('Recording to'))
        started = time.time_ns()
        router.kill()
        assert wait_for(lambda: 'lost the link' in running.errors.text(), 30)
        router.start()
        assert wait_for(lambda: 'is up again' in running.errors.text(), 30)
        restored = time.time_ns()
        # kept as it goes, for a recorder killed before its close
        metadata = folder / 'metadata.yaml'
        assert wait_for(lambda: 'zros.link_outages' in metadata.read_text(), 30)
        running.process.send_signal(signal.SIGINT)
        code, rest = running.finish()
        assert code == 0, rest
        assert 'the link to the router was down 1 time, ' in rest
        assert 'messages published meanwhile are not in the bag' in rest
        with Bag(folder) as bag:
            [outage] = bag.outages
        assert started <= outage.start_ns < outage.end_ns <= restored
        shown = subprocess.run(
            [ZROS, 'bag', 'info', str(folder)],
            capture_output=True,
            text=True,
            timeout=60,
            check=True,
        )
        assert 'Link outages:      1, ' in shown.stdout, shown.stdout + shown.stderr
    finally:
        for started in cli.started:
            if started.process.poll() is None:
                started.process.kill()
                started.process.wait(10)
        router.kill()
