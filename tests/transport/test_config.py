"""Transport settings: precedence, the Zenoh configuration they produce, and clear errors."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from zros.transport import (
    DEFAULT_ENDPOINT,
    Tls,
    Transport,
    TransportConfig,
    TransportError,
    start_router,
)


def setting(config: TransportConfig, key: str) -> object:
    return json.loads(config.to_zenoh().get_json(key))


def test_defaults_reach_the_local_bridge(monkeypatch: pytest.MonkeyPatch) -> None:
    for variable in ('ZROS_CONNECT', 'ZROS_LISTEN', 'ZROS_MODE', 'ZENOH_CONFIG'):
        monkeypatch.delenv(variable, raising=False)
    config = TransportConfig.create()
    assert setting(config, 'mode') == 'client'
    assert setting(config, 'connect/endpoints') == [DEFAULT_ENDPOINT]
    assert setting(config, 'scouting/multicast/enabled') is False
    assert setting(config, 'timestamping/enabled') is True
    assert config.describe() == DEFAULT_ENDPOINT


def test_arguments_beat_environment_beat_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    file = tmp_path / 'zenoh.json5'
    file.write_text(
        '{mode: "peer", connect: {endpoints: ["tcp/10.0.0.1:7447"]}, listen: {endpoints: ["tcp/127.0.0.1:0"]}}'
    )
    monkeypatch.setenv('ZENOH_CONFIG', str(file))
    monkeypatch.delenv('ZROS_CONNECT', raising=False)
    monkeypatch.delenv('ZROS_MODE', raising=False)
    from_file = TransportConfig.create()
    assert setting(from_file, 'mode') == 'peer'
    assert setting(from_file, 'connect/endpoints') == ['tcp/10.0.0.1:7447']
    assert setting(from_file, 'listen/endpoints') == ['tcp/127.0.0.1:0']
    monkeypatch.setenv('ZROS_CONNECT', 'tcp/127.0.0.2:7447, tcp/127.0.0.3:7447')
    monkeypatch.setenv('ZROS_MODE', 'client')
    from_env = TransportConfig.create()
    assert setting(from_env, 'connect/endpoints') == ['tcp/127.0.0.2:7447', 'tcp/127.0.0.3:7447']
    assert setting(from_env, 'mode') == 'client'
    from_args = TransportConfig.create(connect='tcp/127.0.0.4:7447', mode='peer')
    assert setting(from_args, 'connect/endpoints') == ['tcp/127.0.0.4:7447']
    assert setting(from_args, 'mode') == 'peer'


def test_security_and_raw_settings(tmp_path: Path) -> None:
    for name in ('ca.pem', 'me.pem', 'me.key'):
        (tmp_path / name).write_text('x')
    tls = Tls(str(tmp_path / 'ca.pem'), str(tmp_path / 'me.pem'), str(tmp_path / 'me.key'))
    config = TransportConfig.create(
        connect='tls/localhost:7447',
        tls=tls,
        user='robot',
        password='secret',
        shared_memory=False,
        zenoh={'transport/link/tx/lease': 1000},
    )
    assert setting(config, 'transport/link/tls/root_ca_certificate') == str(tmp_path / 'ca.pem')
    assert setting(config, 'transport/link/tls/enable_mtls') is True
    assert setting(config, 'transport/link/tls/connect_certificate') == str(tmp_path / 'me.pem')
    assert setting(config, 'transport/auth/usrpwd/user') == 'robot'
    assert setting(config, 'transport/shared_memory/enabled') is False
    assert setting(config, 'transport/link/tx/lease') == 1000


def test_setting_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match='mode must be "client" or "peer"'):
        TransportConfig.create(mode='router')
    with pytest.raises(ValueError, match=r'^a user needs a password \(password=\)$'):
        TransportConfig.create(user='robot')
    with pytest.raises(TransportError, match=r'the CA certificate .*missing\.pem does not exist'):
        Tls(str(tmp_path / 'missing.pem'))
    with pytest.raises(ValueError, match='both a certificate and a private key') as half:
        (tmp_path / 'ca.pem').write_text('x')
        Tls(str(tmp_path / 'ca.pem'), certificate=str(tmp_path / 'ca.pem'))
    assert str(half.value).endswith('Tls(ca, certificate=..., private_key=...)')
    with pytest.raises(TransportError, match=r'Zenoh configuration file .*none\.json5 does not'):
        TransportConfig.create(config_file=tmp_path / 'none.json5').to_zenoh()


def test_unreachable_router_and_busy_port() -> None:
    with pytest.raises(
        TransportError, match=r'cannot reach a Zenoh router or bridge at tcp/127\.0\.0\.1:1'
    ):
        Transport(TransportConfig.create(connect='tcp/127.0.0.1:1'))
    with start_router() as router:
        assert router.endpoint.startswith('tcp/127.0.0.1:')
        with pytest.raises(TransportError, match='cannot start a router on') as busy:
            start_router(router.endpoint)
        assert 'or port 0 for a free one' in str(busy.value) and 'zros' not in str(busy.value)
        with Transport(TransportConfig.create(connect=router.endpoint)) as transport:
            # Zenoh prints a zid as hex without leading zeros: 1 to 32 digits.
            assert re.fullmatch(r'[0-9a-f]{1,32}', transport.zid)
        assert transport.closed
    assert router.closed


def test_half_a_client_certificate_in_the_environment_names_both_variables(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / 'ca.pem').write_text('x')
    monkeypatch.setenv('ZROS_TLS_CA', str(tmp_path / 'ca.pem'))
    monkeypatch.setenv('ZROS_TLS_CERTIFICATE', str(tmp_path / 'ca.pem'))
    with pytest.raises(ValueError) as info:
        TransportConfig.create()
    assert str(info.value) == 'set ZROS_TLS_CERTIFICATE and ZROS_TLS_KEY together, or neither'


@pytest.mark.parametrize('variable', ['ZROS_TLS_CERTIFICATE', 'ZROS_TLS_KEY'])
def test_a_client_certificate_without_a_ca_in_the_environment_names_the_ca(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, variable: str
) -> None:
    monkeypatch.delenv('ZROS_TLS_CA', raising=False)
    monkeypatch.setenv(variable, str(tmp_path / 'client.pem'))
    with pytest.raises(ValueError, match='need ZROS_TLS_CA') as info:
        TransportConfig.create()
    assert 'Tls(' not in str(info.value)  # a command-line setting, named as such
    (tmp_path / 'ca.pem').write_text('x')
    TransportConfig.create(tls=Tls(tmp_path / 'ca.pem'))  # arguments win: nothing to say
