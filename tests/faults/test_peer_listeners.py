"""A peer's own listening endpoints hold the line its router holds (issue 15.1).

An attacker does not need the router: a peer listens too, and gossip tells everyone where. Each
test dials the PEER's port with a raw Zenoh client (no zros in the way) and checks that what
the router would refuse, the peer refuses too, while the right credentials still get in (so a
refusal is never just a port that speaks another protocol).
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip('cryptography', reason='the test extra (cryptography) is not installed')
if not sys.platform.startswith('linux'):
    pytest.skip('reads listening sockets from /proc', allow_module_level=True)

import zenoh

import zros
from tests.faults.certs import by_name
from tests.faults.listening import is_loopback, listening
from zros.testing import wait_for
from zros.transport import Router, Tls, Transport, TransportConfig, TransportError, start_router
from zros.transport.pki import Certificates, make_certificates
from zros.wire import session_config

REFUSED_WITHIN = 5.0  #: seconds; a refusal takes milliseconds on loopback


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


@pytest.fixture(scope='module')
def pki(tmp_path_factory: pytest.TempPathFactory) -> Certificates:
    return make_certificates(tmp_path_factory.mktemp('pki'), clients=['laptop', 'tablet'])


@pytest.fixture(scope='module')
def foreign(tmp_path_factory: pytest.TempPathFactory) -> Certificates:
    """A second CA and a client it signed: trusted by nobody here."""
    return make_certificates(tmp_path_factory.mktemp('foreign'), clients=['stranger'])


@pytest.fixture
def mtls_router(pki: Certificates) -> Iterator[Router]:
    with start_router('tls/127.0.0.1:0', zenoh=pki.router_settings(mutual=True)) as router:
        yield router


@pytest.fixture
def password_router(tmp_path: Path) -> Iterator[Router]:
    users = tmp_path / 'users'
    users.write_text('laptop:s3cret\n')
    with start_router(zenoh={'transport/auth/usrpwd/dictionary_file': str(users)}) as router:
        yield router


@pytest.fixture
def opened() -> Iterator[Callable[[TransportConfig], Transport]]:
    """``open(config)``: a session closed after the test."""
    sessions: list[Transport] = []

    def open_(config: TransportConfig) -> Transport:
        sessions.append(Transport(config))
        return sessions[-1]

    yield open_
    for session in sessions:
        session.close()


def new_listeners(open_session: Callable[[], object]) -> set[str]:
    """The sockets this process listens on after ``open_session()`` that it did not before."""
    before = listening()
    open_session()
    return listening() - before


def port_of(listeners: set[str]) -> int:
    assert len(listeners) == 1, listeners
    return int(next(iter(listeners)).rpartition(':')[2])


def raw_client(endpoint: str, **settings: Any) -> float | None:
    """Open a raw Zenoh client session to ``endpoint`` with ``settings`` (Zenoh paths).

    Returns None when the session opened (then closes it), else the seconds until refusal.
    """
    config = zenoh.Config.from_json5(
        json.dumps(
            {
                'mode': 'client',
                'connect': {'endpoints': [endpoint]},
                'scouting': {'multicast': {'enabled': False}},
            }
        )
    )
    for key, value in settings.items():
        config.insert_json5(key, json.dumps(value))
    started = time.monotonic()
    try:
        session = zenoh.open(config)
    except zenoh.ZError:
        return time.monotonic() - started
    session.close()  # type: ignore[no-untyped-call]
    return None


def tls_client(pki: Certificates, client: Certificates, name: str) -> dict[str, Any]:
    """Raw settings of a client that trusts ``pki``'s CA and presents ``client``'s ``name``."""
    return {
        'transport/link/tls/root_ca_certificate': str(pki.ca),
        'transport/link/tls/enable_mtls': True,
        'transport/link/tls/connect_certificate': str(client.client_certificate(name)),
        'transport/link/tls/connect_private_key': str(client.client_key(name)),
    }


def test_a_default_peer_listens_on_loopback_only(
    zros_router: Router, opened: Callable[[TransportConfig], Transport], wire: str
) -> None:
    config = session_config(connect=zros_router.endpoint, mode='peer', wire=wire)
    listeners = new_listeners(lambda: opened(config))
    assert listeners, 'a peer listens, so that its peers can link to it'
    assert all(is_loopback(address) for address in listeners), listeners


def test_a_peer_listens_elsewhere_only_when_told(monkeypatch: pytest.MonkeyPatch) -> None:
    def listen(config: TransportConfig) -> object:
        return json.loads(config.to_zenoh().get_json('listen/endpoints'))

    monkeypatch.delenv('ZROS_LISTEN', raising=False)
    assert listen(TransportConfig.create(mode='peer')) == ['tcp/127.0.0.1:0']
    assert listen(TransportConfig.create(mode='peer', listen='0.0.0.0:7000')) == [
        'tcp/0.0.0.0:7000'
    ]
    monkeypatch.setenv('ZROS_LISTEN', 'tcp/192.0.2.1:0')
    assert listen(TransportConfig.create(mode='peer')) == ['tcp/192.0.2.1:0']


def test_mutual_tls_peers_refuse_what_their_router_refuses(
    mtls_router: Router,
    pki: Certificates,
    foreign: Certificates,
    opened: Callable[[TransportConfig], Transport],
    wire: str,
) -> None:
    connect = by_name(mtls_router)
    config = session_config(connect=connect, mode='peer', wire=wire, tls=pki.client_tls('laptop'))
    listeners = new_listeners(lambda: opened(config))
    assert all(is_loopback(address) for address in listeners), listeners
    port = port_of(listeners)
    # the right certificate gets in: the port really is the peer's TLS listener
    assert raw_client(f'tls/localhost:{port}', **tls_client(pki, pki, 'tablet')) is None
    refusals = {
        'no credentials (plain TCP)': raw_client(f'tcp/127.0.0.1:{port}'),
        'no client certificate': raw_client(
            f'tls/localhost:{port}', **{'transport/link/tls/root_ca_certificate': str(pki.ca)}
        ),
        'a certificate from another CA': raw_client(
            f'tls/localhost:{port}', **tls_client(pki, foreign, 'stranger')
        ),
    }
    for client, seconds in refusals.items():
        assert seconds is not None, f'the peer let in a client with {client}'
        assert seconds < REFUSED_WITHIN, f'{client}: refused only after {seconds:.1f} s'


def test_password_peers_refuse_what_their_router_refuses(
    password_router: Router, opened: Callable[[TransportConfig], Transport], wire: str
) -> None:
    config = session_config(
        connect=password_router.endpoint, mode='peer', wire=wire, user='laptop', password='s3cret'
    )
    listeners = new_listeners(lambda: opened(config))
    assert all(is_loopback(address) for address in listeners), listeners
    endpoint = f'tcp/127.0.0.1:{port_of(listeners)}'
    right = {'transport/auth/usrpwd/user': 'laptop', 'transport/auth/usrpwd/password': 's3cret'}
    assert raw_client(endpoint, **right) is None
    refusals = {
        'no credentials': raw_client(endpoint),
        'a wrong password': raw_client(
            endpoint, **{**right, 'transport/auth/usrpwd/password': 'guess'}
        ),
        'an unknown user': raw_client(endpoint, **{**right, 'transport/auth/usrpwd/user': 'eve'}),
    }
    for client, seconds in refusals.items():
        assert seconds is not None, f'the peer let in a client with {client}'
        assert seconds < REFUSED_WITHIN, f'{client}: refused only after {seconds:.1f} s'


def linked(first: Transport, second: Transport) -> bool:
    return second.zid in {str(z) for z in first.session.info.peers_zid()}


def exchange_directly(
    open_pair: Callable[[], tuple[Transport, Transport]],
) -> tuple[Transport, Transport]:
    """Two peers meet at their router, link to each other, and a message goes through; returns
    the pair that did it.

    Two peers dialling each other at once may drop both links ('lost the link to peer', seen
    on a loaded machine), and Zenoh does not dial again: the router relays nothing between
    peers, so that pair stays apart. Such a pair is replaced (twice at most), whether it lost
    the links before or after they showed; a pair still linked that cannot exchange a message
    fails the test at once.
    """
    for _ in range(3):
        first, second = open_pair()
        if not wait_for(lambda: linked(first, second), 30):  # noqa: B023 (called right here)
            continue
        talker = zros.Node('talker', transport=first)
        listener = zros.Node('listener', transport=second)
        sub = listener.create_subscription('std_msgs/msg/String', 'chatter')
        pub = talker.create_publisher('std_msgs/msg/String', 'chatter')
        if pub.wait_for_subscribers(30):
            pub.write(zros.Message('std_msgs/msg/String', data='direct'))
            assert wait_for(sub.has_new_message, 30)
            assert sub.read_message().data == 'direct'
            return first, second
        assert not linked(first, second), 'linked peers could not exchange a message'
        talker.destroy()
        listener.destroy()
    pytest.fail('three pairs of peers lost their direct link')


def test_tls_peers_link_to_each_other_over_tls(
    mtls_router: Router,
    pki: Certificates,
    opened: Callable[[TransportConfig], Transport],
    wire: str,
) -> None:
    connect = by_name(mtls_router)

    def pair() -> tuple[Transport, Transport]:
        first, second = (
            opened(
                session_config(connect=connect, mode='peer', wire=wire, tls=pki.client_tls(name))
            )
            for name in ('laptop', 'tablet')
        )
        return first, second

    first, second = exchange_directly(pair)
    peer_links = [link for link in first.session.info.links() if str(link.zid) == second.zid]
    assert peer_links and all(str(link.src).startswith('tls/') for link in peer_links)


def test_password_peers_link_to_each_other(
    password_router: Router, opened: Callable[[TransportConfig], Transport], wire: str
) -> None:
    def pair() -> tuple[Transport, Transport]:
        first, second = (
            opened(
                session_config(
                    connect=password_router.endpoint,
                    mode='peer',
                    wire=wire,
                    user='laptop',
                    password='s3cret',
                )
            )
            for _ in range(2)
        )
        return first, second

    exchange_directly(pair)


def test_a_tls_peer_without_its_own_certificate_does_not_listen_by_surprise(
    mtls_router: Router, pki: Certificates
) -> None:
    connect = by_name(mtls_router)
    config = TransportConfig.create(connect=connect, mode='peer', tls=Tls(str(pki.ca)))
    with pytest.raises(TransportError, match='needs a certificate and key of its own') as info:
        Transport(config)
    assert "mode='client'" in str(info.value) and 'zros tls init' not in str(info.value)
    shell = info.value.command_line or ''
    assert 'ZROS_TLS_CERTIFICATE' in shell and '--mode client' in shell and 'Tls(' not in shell
    plain = TransportConfig.create(
        connect=connect, mode='peer', tls=pki.client_tls('laptop'), listen='tcp/127.0.0.1:0'
    )
    with pytest.raises(TransportError, match=r'would listen on tcp/127\.0\.0\.1:0') as info:
        Transport(plain)
    assert 'listen=[]' in str(info.value) and 'ZROS_' not in str(info.value)
    shell = info.value.command_line or ''
    assert 'would listen on tcp/127.0.0.1:0' in shell
    assert 'ZROS_LISTEN=tls/127.0.0.1:0' in shell and 'listen=[]' not in shell


def test_a_tls_peer_listens_nowhere_when_told(
    pki: Certificates, opened: Callable[[TransportConfig], Transport]
) -> None:
    with start_router('tls/127.0.0.1:0', zenoh=pki.router_settings(mutual=False)) as server_only:
        connect = by_name(server_only)
        config = TransportConfig.create(
            connect=connect, mode='peer', tls=Tls(str(pki.ca)), listen=[]
        )
        assert new_listeners(lambda: opened(config)) == set()
