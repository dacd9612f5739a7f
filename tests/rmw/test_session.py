"""Sessions for the rmw_zenoh wire: rmw_zenoh's defaults, its environment variables, and zros
peers meeting through a router configured like ``rmw_zenohd`` (spec §7)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

import zros
from zros.node import Node
from zros.testing import wait_for
from zros.transport import Router, Transport, TransportConfig, start_router
from zros.transport.config import SessionDefaults, parse_override
from zros.wire import RmwZenohWire, session_config

String = 'std_msgs/msg/String'
OVERRIDE = 'ZENOH_CONFIG_OVERRIDE'


def setting(config: TransportConfig, key: str) -> object:
    return json.loads(config.to_zenoh().get_json(key))


@pytest.fixture(autouse=True)
def clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ('ZROS_WIRE', 'ZROS_CONNECT', 'ZROS_MODE', 'ZROS_LISTEN', 'ZENOH_CONFIG',
                 'ZENOH_SESSION_CONFIG_URI', 'ZENOH_CONFIG_OVERRIDE'):  # fmt: skip
        monkeypatch.delenv(name, raising=False)


def test_rmw_zenoh_session_defaults() -> None:
    config = session_config(wire='rmw_zenoh')
    assert config.defaults == RmwZenohWire.session
    assert setting(config, 'mode') == 'peer'
    assert setting(config, 'connect/endpoints') == ['tcp/localhost:7447']
    assert setting(config, 'listen/endpoints') == ['tcp/localhost:0']
    assert setting(config, 'scouting/multicast/enabled') is False
    assert setting(config, 'timestamping/enabled') is True
    assert config.describe() == 'tcp/localhost:7447'
    client = session_config(wire='rmw_zenoh', mode='client')
    assert setting(client, 'connect/endpoints') == ['tcp/localhost:7447']
    bridge = session_config()
    assert bridge.defaults == SessionDefaults() and setting(bridge, 'mode') == 'client'
    assert session_config(wire='bridge') == bridge
    with pytest.raises(ValueError, match=r'^wire must be'):
        session_config(wire='dds')


def test_environment_selects_and_overrides(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv('ZROS_WIRE', 'rmw_zenoh')
    assert session_config().defaults == RmwZenohWire.session
    file = tmp_path / 'session.json5'
    file.write_text('{mode: "client", connect: {endpoints: ["tcp/127.0.0.1:7500"]}}')
    monkeypatch.setenv('ZENOH_SESSION_CONFIG_URI', str(file))
    config = session_config()
    assert config.config_file == str(file)
    assert setting(config, 'mode') == 'client'
    assert setting(config, 'connect/endpoints') == ['tcp/127.0.0.1:7500']
    monkeypatch.setenv(
        'ZENOH_CONFIG_OVERRIDE',
        'connect/endpoints=["tcp/127.0.0.1:7600", "tcp/127.0.0.1:7601"];'
        'transport/shared_memory/enabled=false',
    )
    assert setting(config, 'connect/endpoints') == ['tcp/127.0.0.1:7600', 'tcp/127.0.0.1:7601']
    assert setting(config, 'transport/shared_memory/enabled') is False
    monkeypatch.setenv('ZROS_WIRE', 'bridge')  # rmw_zenoh's variables are for that wire only
    bridge = session_config()
    assert bridge.config_file is None
    assert setting(bridge, 'connect/endpoints') == ['tcp/127.0.0.1:7447']
    monkeypatch.setenv('ZROS_WIRE', 'dds')  # the error names where the bad value is
    with pytest.raises(ValueError, match=r'^ZROS_WIRE must be "bridge" or "rmw_zenoh", got'):
        session_config()


def test_override_syntax() -> None:
    assert parse_override('', OVERRIDE) == []
    assert parse_override(' a=1 ; b="x;y" ;c={d: [1;2]};', OVERRIDE) == [
        ('a', '1'),
        ('b', '"x;y"'),
        ('c', '{d: [1;2]}'),
    ]
    with pytest.raises(ValueError, match=r"^ZENOH_CONFIG_OVERRIDE item 'mode' is not path=json5"):
        parse_override('mode', OVERRIDE)
    with pytest.raises(ValueError, match='not path=json5'):
        parse_override('=1', OVERRIDE)


@pytest.fixture
def rmw_zenohd() -> Iterator[Router]:
    """A router with rmw_zenohd's settings that matter: it does not relay between peers."""
    router = start_router(zenoh={'routing/router/peers_failover_brokering': False})
    try:
        yield router
    finally:
        router.close()


def test_peers_meet_through_an_rmw_zenohd_like_router(
    rmw_zenohd: Router, monkeypatch: pytest.MonkeyPatch
) -> None:
    port = rmw_zenohd.endpoint.rsplit(':', 1)[1]
    monkeypatch.setenv('ZENOH_CONFIG_OVERRIDE', f'connect/endpoints=["tcp/localhost:{port}"]')
    monkeypatch.setenv('ZROS_WIRE', 'rmw_zenoh')
    transports = [Transport(session_config(shared_memory=False)) for _ in range(2)]
    nodes: list[Node] = []
    try:
        assert setting(transports[0].config, 'mode') == 'peer'
        nodes = [
            zros.Node(name, transport=t) for name, t in zip(('a', 'b'), transports, strict=True)
        ]
        assert all(node.wire.name == 'rmw_zenoh' for node in nodes)
        sub = nodes[1].create_subscription(String, 'chatter')
        pub = nodes[0].create_publisher(String, 'chatter')
        assert pub.wait_for_subscribers()
        pub.write(zros.Message(String, data='peer to peer'))
        assert wait_for(sub.has_new_message)
        assert sub.read_message().data == 'peer to peer'
        graph = nodes[1].graph
        assert graph.wait_until(lambda: {'/a', '/b'} <= set(graph.nodes()), timeout=5)
    finally:
        for node in nodes:
            node.destroy()
        for transport in transports:
            transport.close()


def test_zros_init_selects_the_wire(zros_router: Router) -> None:
    node = zros.init('R_rmw', connect=zros_router.endpoint, handle_sigint=False, wire='rmw_zenoh')
    try:
        assert (
            node.wire.name == 'rmw_zenoh' and node.transport.config.defaults == RmwZenohWire.session
        )
        assert node._node_token.startswith('@ros2_lv/0/')
    finally:
        zros.shutdown()
