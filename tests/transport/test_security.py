"""Security over a WAN: TLS, mutual TLS and user/password, tested on loopback with fresh PKI."""

from __future__ import annotations

import json
import socket
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip('cryptography', reason='the test extra (cryptography) is not installed')

import zros
from tests.faults.certs import by_name
from zros.cli.main import main as zros_command
from zros.testing import wait_for
from zros.transport import Router, Tls, Transport, TransportConfig, TransportError, start_router
from zros.transport.diagnose import explain_unreachable
from zros.transport.errors import CertificateError
from zros.transport.pki import Certificates, make_certificates


@pytest.fixture(scope='module')
def pki(tmp_path_factory: pytest.TempPathFactory) -> Certificates:
    return make_certificates(tmp_path_factory.mktemp('pki'))


@pytest.fixture(scope='module')
def other_ca(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A CA that signed nothing here: clients trusting it must fail."""
    return make_certificates(tmp_path_factory.mktemp('other')).ca


def tls_router(pki: Certificates, mutual: bool) -> Router:
    return start_router('tls/127.0.0.1:0', zenoh=pki.router_settings(mutual))


def exchange(config_a: TransportConfig, config_b: TransportConfig) -> None:
    """A laptop and a robot node talk through the router, one message each way."""
    with Transport(config_a) as laptop_session, Transport(config_b) as robot_session:
        laptop = zros.Node('laptop', transport=laptop_session)
        robot = zros.Node('robot', transport=robot_session)
        commands = robot.create_subscription('geometry_msgs/msg/Twist', 'cmd_vel')
        status = laptop.create_subscription('std_msgs/msg/String', 'status')
        drive = laptop.create_publisher('geometry_msgs/msg/Twist', 'cmd_vel')
        report = robot.create_publisher('std_msgs/msg/String', 'status')
        assert drive.wait_for_subscribers() and report.wait_for_subscribers()
        drive.write(zros.Message('geometry_msgs/msg/Twist', linear={'x': 0.2}))
        report.write(zros.Message('std_msgs/msg/String', data='moving'))
        assert wait_for(commands.has_new_message) and wait_for(status.has_new_message)
        assert commands.read_message().linear.x == 0.2
        assert status.read_message().data == 'moving'


def refused(config: TransportConfig) -> str:
    started = time.monotonic()
    with pytest.raises(TransportError) as info:
        Transport(config)
    assert time.monotonic() - started < 5
    return str(info.value)


@pytest.fixture
def server_tls(pki: Certificates) -> Iterator[Router]:
    with tls_router(pki, mutual=False) as router:
        yield router


@pytest.fixture
def mutual_tls(pki: Certificates) -> Iterator[Router]:
    with tls_router(pki, mutual=True) as router:
        yield router


def test_tls_with_a_server_certificate(server_tls: Router, pki: Certificates) -> None:
    config = TransportConfig.create(connect=by_name(server_tls), tls=Tls(str(pki.ca)))
    exchange(config, config)


def test_tls_with_the_wrong_ca_names_the_cause(server_tls: Router, other_ca: Path) -> None:
    message = refused(TransportConfig.create(connect=by_name(server_tls), tls=Tls(str(other_ca))))
    assert 'does not verify against' in message and str(other_ca) in message
    assert 'zenoh-bridge-ros2dds' not in for_a_program(message)  # a bridge answered: TLS failed
    message = refused(TransportConfig.create(connect=by_name(server_tls)))
    assert 'is a TLS endpoint but no CA certificate is configured' in message
    assert 'pass tls=zros.transport.Tls("ca.pem")' in for_a_program(message)


def test_mutual_tls(mutual_tls: Router, pki: Certificates) -> None:
    config = TransportConfig.create(connect=by_name(mutual_tls), tls=pki.client_tls('laptop'))
    exchange(config, config)


def test_mutual_tls_without_a_client_certificate_names_the_cause(
    mutual_tls: Router, pki: Certificates
) -> None:
    message = refused(TransportConfig.create(connect=by_name(mutual_tls), tls=Tls(str(pki.ca))))
    assert 'requires a client certificate (mutual TLS)' in message
    assert 'pass Tls(ca, certificate=..., private_key=...)' in for_a_program(message)
    assert 'zenoh-bridge-ros2dds' not in message


@pytest.fixture
def password_router(tmp_path: Path) -> Iterator[Router]:
    users = tmp_path / 'users.txt'
    users.write_text('laptop:s3cret\nrobot:r0b0t\n')
    settings = {
        'transport/auth/usrpwd/dictionary_file': str(users),
        'transport/auth/usrpwd/user': 'router',
        'transport/auth/usrpwd/password': 'router-secret',
    }
    with start_router(zenoh=settings) as router:
        yield router


def test_user_and_password(password_router: Router) -> None:
    laptop = TransportConfig.create(
        connect=password_router.endpoint, user='laptop', password='s3cret'
    )
    robot = TransportConfig.create(connect=password_router.endpoint, user='robot', password='r0b0t')
    exchange(laptop, robot)


def test_wrong_or_missing_password_names_the_cause(password_router: Router) -> None:
    wrong = TransportConfig.create(connect=password_router.endpoint, user='laptop', password='nope')
    assert "is the user 'laptop' and its password right?" in refused(wrong)
    missing = TransportConfig.create(connect=password_router.endpoint)
    assert 'does it require a user and password' in refused(missing)


#: what only a ``zros`` command's user can act on, and what only a program can
CLI_WORDS = ('ZROS_', '--connect', '`zros router`', 'zros tls')
API_WORDS = ('connect=', 'Tls(', 'tls=', 'start_router()', 'user=')


def for_a_program(message: str) -> str:
    assert not [word for word in CLI_WORDS if word in message], message
    return message


def test_nothing_listening_is_said_plainly() -> None:
    message = for_a_program(refused(TransportConfig.create(connect='tcp/127.0.0.1:1')))
    assert 'nothing listens at tcp/127.0.0.1:1' in message
    assert 'zros.transport.start_router() runs one' in message
    assert "Start zenoh-bridge-ros2dds (or zenohd) there, or pass connect='tcp/<host>:7447'." in (
        message
    )


def test_an_unknown_host_is_said_plainly(monkeypatch: pytest.MonkeyPatch) -> None:
    # resolve nothing for real: a DNS query would leave this machine
    def no_such_host(*args: object, **kwargs: object) -> None:
        raise socket.gaierror(socket.EAI_NONAME, 'Name or service not known')

    monkeypatch.setattr(socket, 'getaddrinfo', no_such_host)
    config = TransportConfig.create(connect='tcp/robot.invalid:7447')
    assert "cannot resolve the host 'robot.invalid'" in explain_unreachable(config).api


def test_a_client_certificate_from_another_ca_is_refused(
    mutual_tls: Router, pki: Certificates, tmp_path: Path
) -> None:
    stranger = make_certificates(tmp_path, clients=['stranger'])
    tls = Tls(
        str(pki.ca),
        str(stranger.client_certificate('stranger')),
        str(stranger.client_key('stranger')),
    )
    message = refused(TransportConfig.create(connect=by_name(mutual_tls), tls=tls))
    assert 'rejected the client certificate' in message


def test_tls_settings_from_the_environment(
    mutual_tls: Router, pki: Certificates, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv('ZROS_CONNECT', by_name(mutual_tls))
    monkeypatch.setenv('ZROS_TLS_CA', str(pki.ca))
    monkeypatch.setenv('ZROS_TLS_CERTIFICATE', str(pki.client_certificate('laptop')))
    monkeypatch.setenv('ZROS_TLS_KEY', str(pki.client_key('laptop')))
    config = TransportConfig.create()
    assert config.tls == pki.client_tls('laptop')
    exchange(config, config)
    monkeypatch.setenv('ZROS_TLS_KEY', str(pki.folder / 'missing.key'))
    with pytest.raises(TransportError, match=r'the private key .*missing\.key does not exist'):
        TransportConfig.create()


def test_user_and_password_from_the_environment(
    password_router: Router, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv('ZROS_USER', 'laptop')
    monkeypatch.setenv('ZROS_PASSWORD', 's3cret')
    config = TransportConfig.create(connect=password_router.endpoint)
    assert (config.user, config.password) == ('laptop', 's3cret')
    exchange(config, TransportConfig.create(connect=password_router.endpoint))
    monkeypatch.delenv('ZROS_PASSWORD')
    # the user came from the environment: the error names the variable to set, not password=
    with pytest.raises(ValueError, match=r'^ZROS_USER needs ZROS_PASSWORD: set it too$'):
        TransportConfig.create()


def router_from_config_file(path: Path, endpoint: str) -> Router:
    """What zenoh-bridge-ros2dds -c does with the file, on a loopback port of our choosing."""
    tls = json.loads(path.read_text())['transport']['link']['tls']
    return start_router(endpoint, zenoh={f'transport/link/tls/{k}': v for k, v in tls.items()})


def test_zros_tls_init_end_to_end(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / 'certs'
    assert zros_command(['tls', 'init', str(folder), '--host', 'localhost', '--port', '0']) == 0
    printed = capsys.readouterr().out
    exports = dict(
        line.strip().removeprefix('export ').split('=', 1)
        for line in printed.splitlines()
        if line.strip().startswith('export ')
    )
    assert set(exports) == {'ZROS_CONNECT', 'ZROS_TLS_CA', 'ZROS_TLS_CERTIFICATE', 'ZROS_TLS_KEY'}
    if sys.platform != 'win32':
        for secret in ('ca.key', 'router.key', 'laptop.key', 'router.json5'):
            assert (folder / secret).stat().st_mode & 0o077 == 0, f'{secret} is readable by others'
    with router_from_config_file(folder / 'router.json5', 'tls/127.0.0.1:0') as router:
        for name, value in exports.items():
            monkeypatch.setenv(name, value)
        monkeypatch.setenv('ZROS_CONNECT', by_name(router))
        config = TransportConfig.create()
        exchange(config, config)
    # a second run keeps the CA that signed the robot's certificate
    assert zros_command(['tls', 'init', str(folder)]) == 1
    refused = capsys.readouterr().err
    assert 'will not overwrite' in refused and '(--force replaces them)' in refused
    with pytest.raises(CertificateError, match=r'\(overwrite=True replaces them\)$'):
        make_certificates(folder)


def test_certificate_errors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(CertificateError, match='neither a host name nor an address'):
        make_certificates(tmp_path / 'a', hosts=['tcp/robot:7447'])
    with pytest.raises(CertificateError, match='client names must be distinct'):
        make_certificates(tmp_path / 'b', clients=['router'])
    with pytest.raises(CertificateError, match='use letters, digits'):
        make_certificates(tmp_path / 'b', clients=['../laptop'])
    with pytest.raises(CertificateError, match='at least a day'):
        make_certificates(tmp_path / 'c', days=0)
    with pytest.raises(CertificateError, match='no certificate for'):
        make_certificates(tmp_path / 'd').client_tls('robot')
    monkeypatch.setitem(sys.modules, 'cryptography', None)
    with pytest.raises(CertificateError, match=r"pip install 'zros-client\[tls\]'"):
        make_certificates(tmp_path / 'e')


def test_zros_tls_init_names_this_machine_besides_the_hosts_given(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / 'certs'
    assert zros_command(['tls', 'init', str(folder), '--host', 'robot.example', '--port', '0']) == 0
    assert 'robot.example, localhost, 127.0.0.1, ::1' in capsys.readouterr().out
    client = Certificates(folder, ('robot.example',), ('laptop',)).client_tls('laptop')
    with router_from_config_file(folder / 'router.json5', 'tls/127.0.0.1:0') as router:
        for endpoint in (router.endpoint, by_name(router)):  # by address, then by name
            config = TransportConfig.create(connect=endpoint, tls=client)
            with Transport(config) as session:
                assert session.zid


def test_a_peer_that_cannot_reach_its_router_fails_at_open(
    mutual_tls: Router, pki: Certificates, other_ca: Path
) -> None:
    def peer(endpoint: str, tls: Tls | None = None) -> str:
        return refused(TransportConfig.create(connect=endpoint, mode='peer', listen=[], tls=tls))

    assert 'nothing listens at tcp/127.0.0.1:1' in peer('tcp/127.0.0.1:1')
    no_certificate = peer(by_name(mutual_tls), Tls(str(pki.ca)))
    assert 'requires a client certificate (mutual TLS)' in no_certificate
    assert 'does not verify against' in peer(by_name(mutual_tls), Tls(str(other_ca)))


def test_a_peer_told_not_to_wait_opens_and_warns_until_it_reaches_its_router(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.transport import session

    monkeypatch.setattr(session, 'UNREACHED_WARNING_PERIOD', 0.05)
    config = TransportConfig.create(
        connect='tcp/127.0.0.1:1', mode='peer', listen=[], wait_for_router=False
    )
    with caplog.at_level('WARNING', logger='zros.transport'), Transport(config) as lonely:
        assert not lonely.connected

        def warnings() -> list[str]:
            return [r.getMessage() for r in caplog.records if 'has not reached' in r.getMessage()]

        assert wait_for(lambda: len(warnings()) >= 2)
    assert 'has not reached tcp/127.0.0.1:1 (Zenoh keeps trying): nothing listens' in warnings()[0]
