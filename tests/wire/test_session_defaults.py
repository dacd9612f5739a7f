"""Each wire scheme's session defaults come from its Wire (zros.wire.session_config), and the
Zenoh configuration they make is the one the transport built when it knew the schemes by name:
every key that differs from Zenoh's defaults, for both wires, with and without a mode, connect
and listen endpoints, TLS and the variables. The expected values were taken from the code
before the move (TransportConfig.create(wire=...)) and checked by hand."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import zenoh

from zros.errors import SettingError
from zros.transport import TransportConfig
from zros.transport.config import SessionDefaults
from zros.transport.diagnose import explain_unreachable
from zros.transport.pki import Certificates, make_certificates
from zros.wire import session_config, session_defaults, wire_class

JsonLeaf = object
VARIABLES = (
    'ZROS_WIRE', 'ZROS_CONNECT', 'ZROS_MODE', 'ZROS_LISTEN', 'ZENOH_CONFIG',
    'ZENOH_SESSION_CONFIG_URI', 'ZENOH_CONFIG_OVERRIDE', 'ZROS_TLS_CA', 'ZROS_TLS_CERTIFICATE',
    'ZROS_TLS_KEY', 'ZROS_USER', 'ZROS_PASSWORD',
)  # fmt: skip
#: what every session sets, whatever the wire (a configuration file leaves scouting alone)
COMMON: dict[str, JsonLeaf] = {
    'connect/retry/period_increase_factor': 2.0,
    'connect/retry/period_init_ms': 100,
    'connect/retry/period_max_ms': 1000,
    'scouting/multicast/enabled': False,
    'timestamping/enabled': True,
    'transport/link/tx/queue/congestion_control/drop/max_wait_before_drop_fragments': 25000,
}
#: a peer told where its router is fails at open when it cannot reach it
WAITS: dict[str, JsonLeaf] = {
    'connect/exit_on_failure/client': True,
    'connect/exit_on_failure/peer': True,
    'connect/exit_on_failure/router': False,
    'connect/timeout_ms/client': 0,
    'connect/timeout_ms/peer': 0,
    'connect/timeout_ms/router': -1,
}
CONNECT, LISTEN = 'tcp/127.0.0.1:7500', 'tls/127.0.0.1:7501'
B, R = 'bridge', 'rmw_zenoh'
LOCAL, RMW = 'tcp/127.0.0.1:7447', 'tcp/localhost:7447'
#: (wire, mode, connect?, listen?, tls?) -> (mode, connect endpoint, listen endpoint, waits)
EXPECTED = {
    (B, None, False, False, False): ('client', LOCAL, None, False),
    (B, None, False, False, True): ('client', LOCAL, None, False),
    (B, None, False, True, False): ('client', LOCAL, LISTEN, False),
    (B, None, False, True, True): ('client', LOCAL, LISTEN, False),
    (B, None, True, False, False): ('client', CONNECT, None, False),
    (B, None, True, False, True): ('client', CONNECT, None, False),
    (B, None, True, True, False): ('client', CONNECT, LISTEN, False),
    (B, None, True, True, True): ('client', CONNECT, LISTEN, False),
    (B, 'client', False, False, False): ('client', LOCAL, None, False),
    (B, 'client', False, False, True): ('client', LOCAL, None, False),
    (B, 'client', False, True, False): ('client', LOCAL, LISTEN, False),
    (B, 'client', False, True, True): ('client', LOCAL, LISTEN, False),
    (B, 'client', True, False, False): ('client', CONNECT, None, False),
    (B, 'client', True, False, True): ('client', CONNECT, None, False),
    (B, 'client', True, True, False): ('client', CONNECT, LISTEN, False),
    (B, 'client', True, True, True): ('client', CONNECT, LISTEN, False),
    (B, 'peer', False, False, False): ('peer', None, 'tcp/127.0.0.1:0', False),
    (B, 'peer', False, False, True): ('peer', None, 'tls/127.0.0.1:0', False),
    (B, 'peer', False, True, False): ('peer', None, LISTEN, False),
    (B, 'peer', False, True, True): ('peer', None, LISTEN, False),
    (B, 'peer', True, False, False): ('peer', CONNECT, 'tcp/127.0.0.1:0', True),
    (B, 'peer', True, False, True): ('peer', CONNECT, 'tls/127.0.0.1:0', True),
    (B, 'peer', True, True, False): ('peer', CONNECT, LISTEN, True),
    (B, 'peer', True, True, True): ('peer', CONNECT, LISTEN, True),
    (R, None, False, False, False): ('peer', RMW, 'tcp/localhost:0', False),
    (R, None, False, False, True): ('peer', RMW, 'tls/localhost:0', False),
    (R, None, False, True, False): ('peer', RMW, LISTEN, False),
    (R, None, False, True, True): ('peer', RMW, LISTEN, False),
    (R, None, True, False, False): ('peer', CONNECT, 'tcp/localhost:0', True),
    (R, None, True, False, True): ('peer', CONNECT, 'tls/localhost:0', True),
    (R, None, True, True, False): ('peer', CONNECT, LISTEN, True),
    (R, None, True, True, True): ('peer', CONNECT, LISTEN, True),
    (R, 'client', False, False, False): ('client', RMW, None, False),
    (R, 'client', False, False, True): ('client', RMW, None, False),
    (R, 'client', False, True, False): ('client', RMW, LISTEN, False),
    (R, 'client', False, True, True): ('client', RMW, LISTEN, False),
    (R, 'client', True, False, False): ('client', CONNECT, None, False),
    (R, 'client', True, False, True): ('client', CONNECT, None, False),
    (R, 'client', True, True, False): ('client', CONNECT, LISTEN, False),
    (R, 'client', True, True, True): ('client', CONNECT, LISTEN, False),
    (R, 'peer', False, False, False): ('peer', RMW, 'tcp/localhost:0', False),
    (R, 'peer', False, False, True): ('peer', RMW, 'tls/localhost:0', False),
    (R, 'peer', False, True, False): ('peer', RMW, LISTEN, False),
    (R, 'peer', False, True, True): ('peer', RMW, LISTEN, False),
    (R, 'peer', True, False, False): ('peer', CONNECT, 'tcp/localhost:0', True),
    (R, 'peer', True, False, True): ('peer', CONNECT, 'tls/localhost:0', True),
    (R, 'peer', True, True, False): ('peer', CONNECT, LISTEN, True),
    (R, 'peer', True, True, True): ('peer', CONNECT, LISTEN, True),
}


def flat(value: object, prefix: str = '') -> dict[str, JsonLeaf]:
    """A JSON tree as ``{"path/of/key": leaf}`` (lists are leaves)."""
    if isinstance(value, dict) and value:
        found: dict[str, JsonLeaf] = {}
        for key, item in value.items():
            found.update(flat(item, f'{prefix}/{key}' if prefix else key))
        return found
    return {prefix: value}


def changed(config: TransportConfig) -> dict[str, JsonLeaf]:
    """Every setting of the Zenoh configuration that differs from Zenoh's defaults."""
    default = flat(json.loads(str(zenoh.Config())))
    made = flat(json.loads(str(config.to_zenoh())))
    return {key: value for key, value in made.items() if default.get(key, made) != value}


@pytest.fixture(scope='module')
def pki(tmp_path_factory: pytest.TempPathFactory) -> Certificates:
    return make_certificates(tmp_path_factory.mktemp('pki'))


@pytest.fixture(autouse=True)
def clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in VARIABLES:
        monkeypatch.delenv(name, raising=False)


def tls_settings(pki: Certificates) -> dict[str, JsonLeaf]:
    return {
        'transport/link/tls/connect_certificate': str(pki.client_certificate('laptop')),
        'transport/link/tls/connect_private_key': str(pki.client_key('laptop')),
        'transport/link/tls/enable_mtls': True,
        'transport/link/tls/root_ca_certificate': str(pki.ca),
        'transport/link/tls/verify_name_on_connect': True,
    }


@pytest.mark.parametrize('case', sorted(EXPECTED, key=str), ids=str)
def test_each_wire_makes_the_configuration_it_made_before(
    case: tuple[str, str | None, bool, bool, bool], pki: Certificates
) -> None:
    wire, mode, connect, listen, tls = case
    config = session_config(
        CONNECT if connect else None,
        wire=wire,
        mode=mode,
        listen=LISTEN if listen else None,
        tls=pki.client_tls('laptop') if tls else None,
    )
    want_mode, want_connect, want_listen, waits = EXPECTED[case]
    want = {**COMMON, 'mode': want_mode}
    if want_connect:
        want['connect/endpoints'] = [want_connect]
    if want_listen:
        want['listen/endpoints'] = [want_listen]
    if waits:
        want.update(WAITS)
    if tls:
        want.update(tls_settings(pki))
        if want_listen:  # a node with TLS listens with its own certificate
            want['transport/link/tls/listen_certificate'] = str(pki.client_certificate('laptop'))
            want['transport/link/tls/listen_private_key'] = str(pki.client_key('laptop'))
    assert changed(config) == want
    assert config.describe() == (CONNECT if connect else (RMW if wire == R else LOCAL))
    assert config.defaults == wire_class(wire).session


def test_the_variables_of_each_wire(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    override = 'connect/endpoints=["tcp/127.0.0.1:7700"];transport/shared_memory/enabled=false'
    monkeypatch.setenv('ZENOH_CONFIG_OVERRIDE', override)
    assert changed(session_config(wire=B)) == {
        **COMMON, 'mode': 'client', 'connect/endpoints': [LOCAL],
    }  # fmt: skip
    assert changed(session_config(wire=R)) == {
        **COMMON, 'mode': 'peer', 'connect/endpoints': ['tcp/127.0.0.1:7700'],
        'listen/endpoints': ['tcp/localhost:0'], 'transport/shared_memory/enabled': False,
    }  # fmt: skip
    monkeypatch.delenv('ZENOH_CONFIG_OVERRIDE')
    file = tmp_path / 'session.json5'
    file.write_text('{mode: "client", connect: {endpoints: ["tcp/127.0.0.1:7600"]}}')
    from_file = {**COMMON, 'mode': 'client', 'connect/endpoints': ['tcp/127.0.0.1:7600']}
    del from_file['scouting/multicast/enabled']  # the file's to decide
    monkeypatch.setenv('ZENOH_SESSION_CONFIG_URI', str(file))  # rmw_zenoh's variable
    assert session_config(wire=B).config_file is None
    rmw = session_config(wire=R)
    assert rmw.config_file == str(file) and changed(rmw) == from_file
    assert rmw.describe() == f'the endpoints of {file}'
    monkeypatch.delenv('ZENOH_SESSION_CONFIG_URI')
    monkeypatch.setenv('ZENOH_CONFIG', str(file))  # zros's, on both wires
    for wire in (B, R):
        assert changed(session_config(wire=wire)) == from_file
    monkeypatch.delenv('ZENOH_CONFIG')
    monkeypatch.setenv('ZROS_MODE', 'peer')
    monkeypatch.setenv('ZROS_CONNECT', '127.0.0.1:7800')
    monkeypatch.setenv('ZROS_LISTEN', 'tcp/127.0.0.1:7801')
    for wire in (B, R):
        assert changed(session_config(wire=wire)) == {
            **COMMON, **WAITS, 'mode': 'peer', 'connect/endpoints': ['tcp/127.0.0.1:7800'],
            'listen/endpoints': ['tcp/127.0.0.1:7801'],
        }  # fmt: skip


def test_zros_wire_chooses_the_defaults(monkeypatch: pytest.MonkeyPatch) -> None:
    assert session_defaults() == SessionDefaults() == session_defaults(B)
    assert session_config().defaults == SessionDefaults()
    monkeypatch.setenv('ZROS_WIRE', R)
    assert session_config().defaults == wire_class(R).session == session_defaults()
    assert session_config(wire=B).defaults == SessionDefaults()  # the argument wins
    monkeypatch.setenv('ZROS_WIRE', 'dds')  # the error names where the bad value is
    with pytest.raises(SettingError, match=r'^ZROS_WIRE must be "bridge" or "rmw_zenoh", got'):
        session_config()
    assert session_config(wire=R).defaults.mode == 'peer'
    with pytest.raises(SettingError, match=r'^wire must be "bridge" or "rmw_zenoh", got \'dds\''):
        session_config(wire='dds')


def test_the_transport_knows_no_scheme_by_name(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv('ZROS_WIRE', R)  # a scheme is the wire's to choose, and it says so
    with pytest.warns(UserWarning, match=r'ZROS_WIRE is set.*zros\.wire\.session_config\(\)'):
        bare = TransportConfig.create()
    assert bare == TransportConfig.create(defaults=SessionDefaults())
    with pytest.raises(TypeError, match=r'zros\.wire\.session_config\(wire='):
        TransportConfig.create(wire=R)  # type: ignore[call-arg]


def test_a_failed_session_is_explained_at_the_router_its_defaults_dial() -> None:
    elsewhere = SessionDefaults(mode='peer', connect='tcp/robot.invalid:7447', peer_connects=True)
    config = TransportConfig.create(defaults=elsewhere)
    assert config.describe() == 'tcp/robot.invalid:7447'
    why = explain_unreachable(config).api
    assert why == "cannot resolve the host 'robot.invalid' of tcp/robot.invalid:7447"
