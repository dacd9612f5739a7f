"""Endpoints as people type them (issue 19.3): ``host:port`` means tcp, anything malformed is one
line naming it and the forms that work, through the API and through the ``zros`` command."""

from __future__ import annotations

import pytest

import zros
from tests.cli.conftest import Cli
from zros.errors import ZrosError
from zros.transport import Router, TransportConfig, start_router
from zros.transport.endpoints import FORMS
from zros.transport.errors import EndpointError

#: endpoint -> what the error says is wrong with it
MALFORMED = {
    'tcp/127.0.0.1': 'the port is missing',
    'robot': 'the port is missing',
    '127.0.0.1:99999': 'the port 99999 is out of range',
    'tcp/robot:http': "the port 'http' is not a number",
    'tpc/127.0.0.1:7447': "unknown protocol 'tpc'",
    'tcp://robot:7447': 'an endpoint is not a URL',
    '::1:7447': 'an IPv6 address goes in brackets',
    '[::1:7447': 'an IPv6 address needs its closing "]"',
    'robot 7447': "'robot 7447' is neither a host name nor an address",
    ':7447': 'the host is missing',
}


def test_host_and_port_mean_tcp(monkeypatch: pytest.MonkeyPatch) -> None:
    assert TransportConfig.create(connect='127.0.0.1:7447').connect == ('tcp/127.0.0.1:7447',)
    assert TransportConfig.create(connect=['[::1]:7447', 'localhost:7447']).connect == (
        'tcp/[::1]:7447',
        'tcp/localhost:7447',
    )
    assert TransportConfig.create(listen='TLS/127.0.0.1:0').listen == ('tls/127.0.0.1:0',)
    monkeypatch.setenv('ZROS_CONNECT', 'robot:7447, tls/robot:7447?prio=1')
    config = TransportConfig.create()
    assert config.connect == ('tcp/robot:7447', 'tls/robot:7447?prio=1')
    assert config.describe() == 'tcp/robot:7447, tls/robot:7447?prio=1'


def test_init_connects_without_tcp(zros_router: Router) -> None:
    node = zros.init('no_prefix', connect=zros_router.endpoint.removeprefix('tcp/'))
    try:
        assert node.transport.connected
    finally:
        zros.shutdown()


@pytest.mark.parametrize('endpoint', MALFORMED)
def test_a_malformed_endpoint_is_one_line_through_the_api(endpoint: str) -> None:
    for make in (
        lambda: zros.init('x', connect=endpoint),
        lambda: TransportConfig.create(listen=[endpoint]),
        lambda: start_router(endpoint),
    ):
        with pytest.raises(EndpointError) as info:
            make()
        message = str(info.value)
        assert isinstance(info.value, ValueError) and isinstance(info.value, ZrosError)
        assert message.startswith(f'bad endpoint {endpoint!r}: {MALFORMED[endpoint]}')
        assert message.endswith(FORMS) and '\n' not in message
    assert not zros.ok()  # nothing was opened


def test_the_command_accepts_host_and_port(cli: Cli, zros_router: Router) -> None:
    bare = zros_router.endpoint.removeprefix('tcp/')
    listed = cli.run('topic', 'list', '--connect', bare)
    assert listed.returncode == 0, listed.stderr
    checked = cli.run('doctor', '--wait', '0', '--listen', '0', env={'ZROS_CONNECT': bare})
    assert f'connected to {zros_router.endpoint}' in checked.stdout, checked


@pytest.mark.parametrize('endpoint', ['robot', '127.0.0.1:99999', 'tpc/127.0.0.1:7447'])
def test_a_malformed_endpoint_is_one_line_on_the_command_line(cli: Cli, endpoint: str) -> None:
    for result in (
        cli.run('topic', 'list', '--connect', endpoint),
        cli.run('doctor', env={'ZROS_CONNECT': endpoint}),
        cli.run('router', '--listen', endpoint),
    ):
        assert result.returncode == 2, result
        assert result.stderr.startswith(f'zros: error: bad endpoint {endpoint!r}: ')
        assert MALFORMED[endpoint] in result.stderr
        assert result.stderr.endswith(f'{FORMS}\n') and result.stderr.count('\n') == 1
