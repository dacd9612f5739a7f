"""The WebSocket side of ``zros foxglove``, where the wire does not matter: a client that stops
reading, TLS, the listen address, assets, and the errors of bad settings."""

from __future__ import annotations

import base64
import logging
import socket
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import zros
from tests.gateway.foxglove.client import FoxgloveClient, image
from zros.gateway.common.errors import GatewayError
from zros.gateway.foxglove.sdk import ServerOptions
from zros.testing import wait_for

pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

Make = Callable[..., Any]
TIMEOUT = 20.0


def test_a_slow_client_does_not_stall_a_fast_one(
    gateway: Make, foxglove_client: Make, zros_node: Make, caplog: pytest.LogCaptureFixture
) -> None:
    """A client that stops reading loses its oldest messages once its queue holds
    ``client_buffer`` bytes, and is told; the fast client gets each frame while it sleeps; the
    slow one, reading again, ends with the newest frame."""
    talker = zros_node('talker')
    pub = talker.create_publisher('sensor_msgs/msg/Image', '/camera')
    server = gateway(client_buffer=1_000_000)
    fast: FoxgloveClient = foxglove_client(server.url)
    slow: FoxgloveClient = foxglove_client(server.url)
    slow_subscription = slow.subscribe('/camera')
    slow.send('pauseReading')
    fast_subscription = fast.subscribe('/camera')
    assert wait_for(lambda: server.watched() == {'/camera': 2}, TIMEOUT)
    assert pub.wait_for_subscribers(TIMEOUT)
    sent = 0
    last = b''
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        while server.dropped == 0:  # until the slow one's queue overflows
            assert sent < 2000, 'the slow client never lost a message'
            frame = image(256, 170, sent)  # 130 kB
            last = frame.serialize()
            pub.write(frame)
            sent += 1
            # each frame reaches the fast client while the slow one sleeps
            fast.wait(lambda e, n=sent: fast.count(fast_subscription) >= n, TIMEOUT)
    assert fast.count(fast_subscription) == sent
    assert fast.last(fast_subscription) == last
    assert server.slow_client_reports >= 1
    assert 'does not read fast enough' in caplog.text
    assert not [e for e in fast.of('status') if 'read fast enough' in e['status']['message']]
    slow.send('resumeReading')
    slow.wait(lambda e: slow.last(slow_subscription) == last, TIMEOUT)
    told = slow.wait(lambda e: e['ev'] == 'status' and 'read fast enough' in e['status']['message'])
    assert told['status']['level'] == 1  # a warning
    assert slow.count(slow_subscription) < sent  # its oldest messages were dropped


def test_tls_serves_wss_only(
    tmp_path: Path, gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    pytest.importorskip('cryptography', reason='certificates need the tls extra')
    from zros.transport.pki import make_certificates

    certificates = make_certificates(tmp_path / 'pki', hosts=('127.0.0.1', 'localhost'))
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/String', '/chatter')
    server = gateway(tls_cert=certificates.router_certificate, tls_key=certificates.router_key)
    assert server.url.startswith('wss://127.0.0.1:')
    client: FoxgloveClient = foxglove_client(server.url, ca=str(certificates.ca))
    subscription = client.subscribe('/chatter')
    assert pub.wait_for_subscribers(TIMEOUT)
    message = zros.Message('std_msgs/msg/String', data='encrypted')
    pub.write(message)
    assert client.wait_messages(subscription) == [message.serialize()]
    plain: FoxgloveClient = foxglove_client(server.url.replace('wss://', 'ws://'))
    plain.wait(lambda e: e['ev'] in ('error', 'close'))
    assert not plain.of('serverInfo')


def test_an_address_beyond_loopback_warns(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        ServerOptions(address='127.0.0.1').check()
        assert not caplog.records
        ServerOptions(address='0.0.0.0').check()  # checked only: nothing listens there
    assert 'anyone who reaches this machine' in caplog.text
    assert 'not encrypted' in caplog.text


@pytest.mark.parametrize(
    ('options', 'error'),
    [
        ({'topics': ['(']}, 'not a valid regex'),
        (
            {'tls_cert': '/nonexistent/cert.pem', 'tls_key': '/nonexistent/key.pem'},
            'the certificate /nonexistent/cert.pem does not exist',
        ),
        ({'tls_cert': '/nonexistent/cert.pem'}, 'both a certificate and its private key'),
        ({'asset_paths': ['/nonexistent/meshes']}, 'does not exist'),
        ({'message_backlog': 0}, 'at least 1'),
        ({'client_buffer': 0}, 'at least 1 byte'),
        ({'port': 70000}, 'the port must be 0 to 65535'),
    ],
)
def test_bad_settings_are_refused(gateway: Make, options: dict[str, Any], error: str) -> None:
    with pytest.raises(GatewayError, match=error):
        gateway(**options)


def test_a_port_in_use_is_refused(gateway: Make) -> None:
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        with pytest.raises(GatewayError, match='cannot start the Foxglove server'):
            gateway(port=taken.getsockname()[1])


def test_without_the_sdk_the_error_says_what_to_install(
    monkeypatch: pytest.MonkeyPatch, zros_node: Make
) -> None:
    from zros.gateway.foxglove.server import serve

    monkeypatch.setitem(sys.modules, 'foxglove', None)
    with pytest.raises(GatewayError, match=r"pip install 'zros-client\[foxglove\]'"):
        serve(node=zros_node('zros_foxglove'), port=0)


# --- assets ------------------------------------------------------------------------------------


@pytest.fixture
def asset_folders(tmp_path: Path) -> dict[str, Path]:
    """A folder of packages, an install prefix, a package folder, and a secret beside them."""
    packages = tmp_path / 'src'
    (packages / 'robot_description' / 'meshes').mkdir(parents=True)
    (packages / 'robot_description' / 'meshes' / 'base.stl').write_bytes(b'solid base\x00\xff')
    prefix = tmp_path / 'install'
    (prefix / 'share' / 'arm' / 'meshes').mkdir(parents=True)
    (prefix / 'share' / 'arm' / 'meshes' / 'link 1.dae').write_bytes(b'<COLLADA/>')
    own = tmp_path / 'gripper_pkg'
    own.mkdir()
    (own / 'package.xml').write_text('<package><name>gripper</name></package>')
    (own / 'finger.obj').write_bytes(b'o finger')
    (tmp_path / 'secret.txt').write_text('do not serve')
    (packages / 'robot_description' / 'leak.stl').symlink_to(tmp_path / 'secret.txt')
    (tmp_path / 'elsewhere').mkdir()
    (tmp_path / 'elsewhere' / 'key.stl').write_text('do not serve')
    (packages / 'outside').symlink_to(tmp_path / 'elsewhere')  # a package folder leading out
    return {'packages': packages, 'prefix': prefix, 'own': own}


def test_assets_are_served_from_the_named_folders_only(
    asset_folders: dict[str, Path], gateway: Make, foxglove_client: Make
) -> None:
    server = gateway(asset_paths=list(asset_folders.values()))
    client: FoxgloveClient = foxglove_client(server.url)
    assert 'assets' in client.server_info()['capabilities']
    served = {
        'package://robot_description/meshes/base.stl': b'solid base\x00\xff',
        'package://arm/meshes/link%201.dae': b'<COLLADA/>',
        'package://gripper/finger.obj': b'o finger',
        f'file://{asset_folders["own"]}/finger.obj': b'o finger',
    }
    for uri, data in served.items():
        response = client.fetch_asset(uri)
        assert response['status'] == 0, response
        assert base64.b64decode(response['data']) == data
    refused = {
        'package://robot_description/../../secret.txt': 'inside the package',
        'package://robot_description/leak.stl': 'outside the asset folders',
        'package://outside/key.stl': 'outside the asset folders',
        'package://../secret.txt': "'..' is not a package name",
        'package://../src/robot_description/meshes/base.stl': 'not a package name',
        'package://.../x': 'not a package name',
        'package://robot_description/meshes/missing.stl': 'no such file',
        'package://unknown/mesh.stl': "no package 'unknown'",
        f'file://{asset_folders["packages"].parent}/secret.txt': 'inside the asset folders',
        'https://example.com/mesh.stl': 'only package:// and file://',
    }
    for uri, reason in refused.items():
        response = client.fetch_asset(uri)
        assert response['status'] == 1, response
        assert reason in response['error'], (uri, response['error'])


def test_an_asset_beyond_the_size_bound_is_refused(
    asset_folders: dict[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.gateway.foxglove import assets

    monkeypatch.setattr(assets, 'MAX_ASSET_BYTES', 4)
    served = assets.Assets([asset_folders['own']])
    with pytest.raises(GatewayError, match='more than the 4 served'):
        served.fetch('package://gripper/finger.obj')


def test_no_asset_folders_no_assets_capability(gateway: Make, foxglove_client: Make) -> None:
    client: FoxgloveClient = foxglove_client(gateway().url)
    assert 'assets' not in client.server_info()['capabilities']
