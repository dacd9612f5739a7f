"""``zros rosbridge``: the command serves the graph to rosbridge clients until Ctrl-C."""

from __future__ import annotations

import argparse
import re
import signal
from typing import Any

import pytest

import zros
from tests.cli.conftest import Cli
from tests.gateway.rosbridge.clients import RawClient

pytest.importorskip('websockets', reason='the websockets library (the rosbridge extra) is missing')

TIMEOUT = 60.0


def _url(line: str) -> str:
    found = re.search(r'wss?://\S+', line)
    assert found is not None, line
    return found.group(0)


def test_the_command_serves_the_graph(cli: Cli, zros_node: Any) -> None:
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/String', '/chatter')
    running = cli.start('rosbridge', '--port', '0', '--topics-glob', "['/chat*']")
    url = _url(running.wait_line(lambda line: line.startswith('rosbridge: ')))
    assert url.startswith('ws://127.0.0.1:')
    client = RawClient(url)
    try:
        client.send(op='subscribe', topic='/chatter', type='std_msgs/String')
        assert pub.wait_for_subscribers(TIMEOUT)
        pub.write(zros.Message('std_msgs/msg/String', data='through the command'))
        message = client.wait(lambda m: m.get('op') == 'publish', TIMEOUT)
        assert message == {
            'op': 'publish',
            'topic': '/chatter',
            'msg': {'data': 'through the command'},
        }
        client.send(op='subscribe', topic='/rosout', id='refused')
        assert 'not allowed' in client.status('/rosout')['msg']  # the topics glob
    finally:
        client.close()
    running.process.send_signal(signal.SIGINT)
    code, _ = running.finish()
    assert code == 0


@pytest.mark.parametrize(
    ('args', 'error'),
    [
        (
            ['--tls-cert', '/nonexistent.pem', '--tls-key', '/nonexistent.key'],
            'certificate /nonexistent.pem does not exist',
        ),
        (['--tls-cert', '/nonexistent.pem'], 'both a certificate and its private key'),
    ],
)
def test_bad_arguments_fail_with_a_message(cli: Cli, args: list[str], error: str) -> None:
    result = cli.run('rosbridge', '--port', '0', *args)
    assert result.returncode == 1
    assert error in result.stderr
    assert 'Traceback' not in result.stderr


def test_a_port_out_of_range_is_a_usage_error(cli: Cli) -> None:
    result = cli.run('rosbridge', '--port', '70000')
    assert result.returncode == 2
    assert 'a port is 0 to 65535' in result.stderr


def test_the_safety_options(cli: Cli, zros_node: Any) -> None:
    from websockets.exceptions import InvalidStatus

    listener = zros_node('listener').create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    running = cli.start(
        'rosbridge', '--port', '0', '--read-only', '--client-buffer', '1MiB',
        '--allow-origin', 'https://dashboard.example', '--max-clients', '1',
    )  # fmt: skip
    line = running.wait_line(lambda line: line.startswith('rosbridge: '))
    assert 'read-only' in line
    url = _url(line)
    with pytest.raises(InvalidStatus) as refused:
        RawClient(url, origin='https://evil.example')
    assert refused.value.response.status_code == 403
    client = RawClient(url, origin='https://dashboard.example')
    try:
        client.send(op='publish', topic='/cmd_vel', msg={'linear': {'x': 1.0}}, id='p')
        status = client.wait(lambda m: m.get('id') == 'p', TIMEOUT)
        assert status['op'] == 'status' and 'read-only' in status['msg']
        with pytest.raises(InvalidStatus) as full:
            RawClient(url)
        assert full.value.response.status_code == 503
    finally:
        client.close()
    assert listener.read_message() is None
    running.process.send_signal(signal.SIGINT)
    code, _ = running.finish()
    assert code == 0
    refusals = [x for x in running.errors.text().splitlines() if 'evil.example' in x]
    assert len(refusals) == 1 and '--allow-origin' in refusals[0]  # one line, naming the option


def parser_of(command: str) -> argparse.ArgumentParser:
    """The parser of ``zros COMMAND``."""
    from zros.cli.main import build_parser

    parser = build_parser([command])
    (commands,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    found: argparse.ArgumentParser = commands.choices[command]
    return found


def test_the_gateway_commands_share_their_listen_and_safety_options() -> None:
    def options(command: str) -> dict[str, tuple[object, ...]]:
        return {
            action.option_strings[-1]: (
                action.help, action.type, action.default, action.metavar, action.nargs,
                type(action),
            )
            for action in parser_of(command)._actions
        }  # fmt: skip

    foxglove, rosbridge = options('foxglove'), options('rosbridge')
    shared = ['--address', '--tls-cert', '--tls-key', '--read-only', '--throttle']
    for flag in [*shared, '--client-buffer', '--max-clients']:
        assert foxglove[flag] == rosbridge[flag], flag
    # in the same order: where they listen first, what clients may do after their own options
    assert [f for f in foxglove if f in rosbridge] == [f for f in rosbridge if f in foxglove]
    # the port and the origins differ only in their defaults
    assert foxglove['--port'][0] == 'TCP port (default 8765; 0: any)'
    assert rosbridge['--port'][0] == 'TCP port (default 9090; 0: any)'
    assert foxglove['--port'][2:] == (8765, *rosbridge['--port'][3:])
    assert foxglove['--port'][1] is rosbridge['--port'][1]
    origins = str(foxglove['--allow-origin'][0])
    assert origins.replace(' and https://app.foxglove.dev (the Foxglove web app)', '') == str(
        rosbridge['--allow-origin'][0]
    )
    assert foxglove['--allow-origin'][1:] == rosbridge['--allow-origin'][1:]
    # the name filters: each server's own flags and syntax, read alike (one or more, repeatable)
    filters = {'--topics': '--topics-glob', '--services': '--services-glob',
               '--params': '--params-glob'}  # fmt: skip
    for regex, glob in filters.items():
        assert foxglove[regex][4:] == rosbridge[glob][4:] == ('+', argparse._ExtendAction)
        assert foxglove[regex][2] is rosbridge[glob][2] is None  # no filter: everything
    # the same words give the same settings
    words = ['--port', '0', '--address', '0.0.0.0', '--tls-cert', 'c.pem', '--tls-key',
             'k.pem', '--read-only', '--throttle', '/a=2', '--allow-origin', 'https://x.example',
             '--client-buffer', '1MiB', '--max-clients', '7']  # fmt: skip
    keys = ['port', 'address', 'tls_cert', 'tls_key', 'read_only', 'throttle', 'allow_origin',
            'client_buffer', 'max_clients']  # fmt: skip
    read = [vars(parser_of(c).parse_args(words)) for c in ('foxglove', 'rosbridge')]
    assert {k: read[0][k] for k in keys} == {k: read[1][k] for k in keys}
    assert read[0]['client_buffer'] == 1024**2 and read[0]['throttle'] == ['/a=2']
    assert read[0]['max_clients'] == 7


@pytest.mark.parametrize('command', ['foxglove', 'rosbridge'])
def test_the_commands_defaults_are_the_gateways(command: str) -> None:
    """What ``zros foxglove`` and ``zros rosbridge`` listen on and bound by default is what
    ``zros.foxglove.serve`` and ``zros.rosbridge.serve`` do."""
    import importlib
    import inspect

    serve = importlib.import_module(f'zros.{command}').serve
    defaults = {name: value.default for name, value in inspect.signature(serve).parameters.items()}
    read = vars(parser_of(command).parse_args([]))
    for key in ('port', 'client_buffer', 'max_clients'):
        assert read[key] == defaults[key], key
    assert read['port'] == {'foxglove': 8765, 'rosbridge': 9090}[command]


def test_a_bound_of_clients_below_one_is_a_usage_error(cli: Cli) -> None:
    result = cli.run('rosbridge', '--port', '0', '--max-clients', '0')
    assert result.returncode == 2
    assert 'must be at least 1, not 0' in result.stderr
