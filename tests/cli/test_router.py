"""``zros router`` through the console script: a router from the shell that other commands reach."""

from __future__ import annotations

import signal
import subprocess
from pathlib import Path

import pytest

import zros
from tests.cli.conftest import Cli, Running
from zros.transport import start_router

LISTENING = 'zros router listening on '


def endpoint_of(router: Running) -> str:
    """Where the router says it listens (its first line of the kind)."""
    return router.wait_line(lambda line: line.startswith(LISTENING))[len(LISTENING) :]


def stopped(router: Running, how: signal.Signals = signal.SIGINT) -> tuple[int, str]:
    """Stop the router; its exit code and what it wrote on stderr."""
    router.process.send_signal(how)
    code, _ = router.finish()
    return code, router.errors.text()


def one_line_error(result: subprocess.CompletedProcess[str], code: int, *words: str) -> None:
    assert result.returncode == code, result
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith('zros: error: '), result.stderr
    assert all(word in lines[0] for word in words), lines[0]


@pytest.mark.parametrize('how', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_a_router_from_the_shell_serves_the_other_commands(cli: Cli, how: signal.Signals) -> None:
    router = cli.start('router', '--listen', 'tcp/127.0.0.1:0')
    endpoint = endpoint_of(router)
    assert endpoint.startswith('tcp/127.0.0.1:')
    node = zros.Node('talker', connect=endpoint, mode='client')
    try:
        node.create_publisher('std_msgs/msg/String', 'chatter')
        listed = cli.run('topic', 'list', '--connect', endpoint)
        assert listed.returncode == 0, listed.stderr
        assert '/chatter' in listed.stdout.split()
    finally:
        node.destroy()
        node.transport.close()
    assert stopped(router, how) == (0, '')


def test_a_busy_port_is_one_line(cli: Cli) -> None:
    with start_router() as taken:
        busy = cli.run('router', '--listen', taken.endpoint)
    one_line_error(busy, 1, f'cannot start a router on {taken.endpoint}', 'port is taken')
    assert 'or --listen elsewhere' in busy.stderr and 'port 0' not in busy.stderr


def test_listening_beyond_this_machine_warns(cli: Cli) -> None:
    # 198.51.100.7 (a documentation range) is no address of this machine: the bind fails after
    # the warning, and nothing ever listens beyond loopback
    result = cli.run('router', '--listen', 'tcp/198.51.100.7:0')
    warning, error = result.stderr.splitlines()
    assert warning.startswith('zros router: warning: tcp/198.51.100.7:0 accepts connections')
    assert 'anyone who reaches it joins the graph' in warning
    assert result.returncode == 1 and error.startswith('zros: error: cannot start a router')
    loopback = cli.start('router', '--listen', '[::1]:0')
    assert endpoint_of(loopback).startswith('tcp/[::1]:')
    assert stopped(loopback) == (0, '')


def test_a_mutual_tls_router_from_the_shell(cli: Cli, tmp_path: Path) -> None:
    pytest.importorskip('cryptography', reason='the test extra (cryptography) is not installed')
    from zros.transport.pki import make_certificates

    pki = make_certificates(tmp_path / 'certs')
    files = ['--tls-cert', str(pki.router_certificate), '--tls-key', str(pki.router_key)]
    router = cli.start('router', *files, '--tls-ca', str(pki.ca), '--listen', 'tls/127.0.0.1:0')
    endpoint = endpoint_of(router).replace('127.0.0.1', 'localhost')
    laptop = {
        'ZROS_TLS_CA': str(pki.ca),
        'ZROS_TLS_CERTIFICATE': str(pki.client_certificate('laptop')),
        'ZROS_TLS_KEY': str(pki.client_key('laptop')),
    }
    listed = cli.run('topic', 'list', '--connect', endpoint, env=laptop)
    assert listed.returncode == 0, listed.stderr
    refused = cli.run('topic', 'list', '--connect', endpoint, env={'ZROS_TLS_CA': str(pki.ca)})
    one_line_error(refused, 1, 'requires a client certificate', 'set ZROS_TLS_CERTIFICATE and')
    assert not [w for w in ('Tls(', 'certificate=', 'zenoh-bridge') if w in refused.stderr]
    assert stopped(router) == (0, '')
    plain = cli.run('router', *files, '--listen', 'tcp/127.0.0.1:0')
    one_line_error(plain, 1, 'tls/ endpoints only, not tcp/127.0.0.1:0')
    swapped = cli.run('router', '--tls-cert', str(pki.router_key), '--tls-key', files[1])
    one_line_error(swapped, 1, str(pki.router_key), 'holds a private key, not a certificate')


def test_a_password_router_from_the_shell(cli: Cli) -> None:
    secret = 'correct-horse-7'
    router = cli.start(
        'router', '--listen', 'tcp/127.0.0.1:0', '--user', 'laptop', env={'ZROS_PASSWORD': secret}
    )
    endpoint = endpoint_of(router)
    right = cli.run(
        'topic', 'list', '--connect', endpoint, env={'ZROS_USER': 'laptop', 'ZROS_PASSWORD': secret}
    )
    assert right.returncode == 0, right.stderr
    wrong = cli.run(
        'topic', 'list', '--connect', endpoint, env={'ZROS_USER': 'laptop', 'ZROS_PASSWORD': 'x'}
    )
    one_line_error(wrong, 1, "is the user 'laptop' and its password right?")
    assert secret not in ' '.join(router.seen) + str(router.process.args)
    assert stopped(router) == (0, '')
    no_password = cli.run('router', '--user', 'laptop', env={'ZROS_PASSWORD': ''})
    one_line_error(no_password, 1, 'set ZROS_PASSWORD')


def test_a_router_from_the_shell_downsamples_and_says_so(cli: Cli) -> None:
    router = cli.start('router', '--listen', 'tcp/127.0.0.1:0', '--downsample', '/camera/*=2')
    endpoint = endpoint_of(router)
    router.wait_line(lambda line: 'sent with drop leave as block_first' in line)
    router.wait_line(
        lambda line: line == '  /camera/*: at most 2 messages a second out of each link'
    )
    node = zros.Node('viewer', connect=endpoint, mode='client')
    try:  # the router's settings reach Zenoh: it rejects a rule that does not parse
        assert node.create_subscription('std_msgs/msg/Int32', '/camera/a') is not None
    finally:
        node.destroy()
        node.transport.close()
    assert stopped(router) == (0, '')
    for wrong in ('/camera', '/camera=0', '=2', '/a//b=1', '/camera=fast'):
        result = cli.run('router', '--downsample', wrong)
        assert result.returncode == 2 and 'give TOPIC=HZ with HZ > 0' in result.stderr, wrong


def test_a_tls_router_suggests_an_address_its_certificate_names(cli: Cli, tmp_path: Path) -> None:
    pytest.importorskip('cryptography', reason='the test extra (cryptography) is not installed')
    from zros.transport.pki import make_certificates

    pki = make_certificates(tmp_path / 'certs', hosts=['localhost'])
    files = ['--tls-cert', str(pki.router_certificate), '--tls-key', str(pki.router_key)]
    router = cli.start('router', *files, '--listen', 'tls/127.0.0.1:0')
    port = endpoint_of(router).rsplit(':', 1)[1]
    suggested = router.wait_line(lambda line: 'connect with' in line)
    assert f'--connect tls/localhost:{port} or ZROS_CONNECT=tls/localhost:{port}' in suggested
    listed = cli.run(
        'topic', 'list', '--connect', f'tls/localhost:{port}', env={'ZROS_TLS_CA': str(pki.ca)}
    )
    assert listed.returncode == 0, listed.stderr
    assert stopped(router) == (0, '')


def test_nothing_listening_tells_the_shell_user_what_to_run(cli: Cli) -> None:
    result = cli.run('topic', 'list', '--connect', 'tcp/127.0.0.1:1')
    one_line_error(result, 1, 'nothing listens at tcp/127.0.0.1:1', '`zros router` runs one')
    assert '--connect or ZROS_CONNECT=tcp/<host>:7447.' in result.stderr
    assert not [w for w in ('connect=', 'start_router', 'Tls(') if w in result.stderr]
