"""``zros doctor`` against a router in the test process, and against nothing."""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from tests.cli.conftest import Cli


@contextmanager
def logging_forever(node: Any) -> Iterator[None]:
    """``node`` logs a line to /rosout every 50 ms while in the block."""
    stop = threading.Event()

    def log_forever() -> None:
        while not stop.wait(0.05):
            node.get_logger().info('still here')

    logger = threading.Thread(target=log_forever, daemon=True)
    logger.start()
    try:
        yield
    finally:
        stop.set()
        logger.join(5)


def test_doctor_reports_the_router_graph_and_clock(cli: Cli, zros_node: Callable[..., Any]) -> None:
    node = zros_node('chatty')  # logs to /rosout, serves parameters
    node.create_publisher('std_msgs/msg/String', '/chatter', 10)
    with logging_forever(node):
        result = cli.run('doctor', '--listen', '10')
    assert result.returncode == 0, result.stdout + result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith('zros ') and 'eclipse-zenoh 1.' in lines[0]
    assert lines[1] == 'session'
    assert lines[2].startswith(f'  ok    connected to {cli.endpoint} as ')
    assert lines[3].startswith('  ok    router ') and ' runs Zenoh v1.' in lines[3]
    assert '  warn  no zenoh-bridge-ros2dds answered' in result.stdout
    assert '  ok    wire schemes present: bridge' in result.stdout
    graph = next(line for line in lines if line.endswith('actions'))
    assert graph.startswith('  ok    1 node, ')
    skew = next(line for line in lines if 'from /rosout stamps' in line)
    seconds = float(skew.split('this clock is ')[1].split(' s')[0])
    assert abs(seconds) < 0.5  # one machine, one clock
    assert lines[-1] == 'no problems found'


def test_doctor_fails_clearly_without_a_router(cli: Cli) -> None:
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(('127.0.0.1', 0))
        port = probe.getsockname()[1]
    result = cli.run('doctor', '--connect', f'tcp/127.0.0.1:{port}')
    assert result.returncode == 1
    assert f'  FAIL  cannot reach a Zenoh router or bridge at tcp/127.0.0.1:{port}' in result.stdout


def test_doctor_hears_the_clocks_of_an_rmw_zenoh_graph(
    cli: Cli, zros_node: Callable[..., Any]
) -> None:
    node = zros_node('sim', wire='rmw_zenoh')  # logs to /rosout under rmw_zenoh's keys
    node.create_publisher('rosgraph_msgs/msg/Clock', '/clock', 10)
    with logging_forever(node):
        result = cli.run('doctor', '--listen', '10', '--wire', 'rmw_zenoh')
    assert result.returncode == 0, result.stdout + result.stderr
    assert '  ok    wire schemes present: rmw_zenoh' in result.stdout
    assert '  warn  /clock is published' in result.stdout
    skew = next((line for line in result.stdout.splitlines() if 'from /rosout stamps' in line), '')
    assert skew, result.stdout
    assert abs(float(skew.split('this clock is ')[1].split(' s')[0])) < 0.5
