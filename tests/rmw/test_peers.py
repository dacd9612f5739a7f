"""Interop with rmw_zenoh implementations written by others, from PyPI: zenoh-ros2-sdk and
pyzeros. Their publishers and service clients against zros and back, each in the other's graph
where the peer has one; where a peer departs from shared/specs/rmw-zenoh-protocol.md, the test
shows it and zros follows the spec. Each part skips when its peer is not installed (the ``test``
extra installs both)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
import zenoh

import zros
from zros.cdr import default_registry
from zros.cdr.hashing import type_hash
from zros.cdr.model import ServiceDef
from zros.cdr.render import render_definition
from zros.keyexpr.attachment import Attachment
from zros.keyexpr.rmw_zenoh import RmwQoS, gid, parse_token
from zros.node import Node
from zros.testing import spinning, wait_for
from zros.transport import Router, Transport

String = 'std_msgs/msg/String'
ADD = 'example_interfaces/srv/AddTwoInts'
SET_BOOL = 'std_srvs/srv/SetBool'


@pytest.fixture
def zros_wire() -> str:
    return 'rmw_zenoh'


def tokens_of(transport: Transport, node_name: str) -> list[str]:
    replies = transport.session.liveliness().get('@ros2_lv/0/**')
    found = [str(r.ok.key_expr) for r in replies if r.ok is not None]
    return [t for t in found if t.split('/')[8] == node_name]


def capture(transport: Transport, key: str) -> tuple[list[Any], Any]:
    samples: list[Any] = []
    return samples, transport.session.declare_subscriber(key, samples.append)


# --- zenoh-ros2-sdk -----------------------------------------------------------------------------


def write_definitions(root: Path, names: list[str]) -> None:
    """The peer reads .msg/.srv files: write them from zros's own definitions (never fetched)."""
    registry = default_registry()
    for name in names:
        package, kind, short = name.split('/')
        folder = root / package / kind
        folder.mkdir(parents=True, exist_ok=True)
        definition = registry.definition(name)
        (folder / f'{short}.{kind}').write_text(render_definition(definition))
        if isinstance(definition, ServiceDef):
            for part, message in (
                ('Request', definition.request),
                ('Response', definition.response),
            ):
                (folder / f'{short}_{part}.msg').write_text(render_definition(message))


@pytest.fixture
def sdk(zros_router: Router, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """zenoh-ros2-sdk on a session of its own (peer to the test router), offline."""
    module = pytest.importorskip(
        'zenoh_ros2_sdk', reason='zenoh-ros2-sdk is not installed (pip install -e .[test])'
    )
    from zenoh_ros2_sdk import message_registry, session

    def offline(*args: object, **kwargs: object) -> None:
        raise RuntimeError('zenoh-ros2-sdk may not fetch definitions from the network here')

    monkeypatch.setattr(message_registry, 'clone_to_cache', offline)
    monkeypatch.setattr(message_registry, 'get_message_file_path', offline)
    for name in ('ZENOH_CONFIG_OVERRIDE', 'ZENOH_SESSION_CONFIG_URI', 'ROS_DOMAIN_ID'):
        monkeypatch.delenv(name, raising=False)
    write_definitions(tmp_path, [String, ADD, 'std_msgs/msg/Char'])
    monkeypatch.setattr(
        message_registry, '_registry', message_registry.MessageRegistry(str(tmp_path))
    )
    port = int(zros_router.endpoint.rsplit(':', 1)[1])
    instance = session.ZenohSession.get_instance('127.0.0.1', port)
    module.port = port
    try:
        yield module
    finally:
        instance.session.close()
        session.ZenohSession._instance = None


def test_sdk_topics_both_ways(sdk: Any, zros_node: Callable[..., Node]) -> None:
    node = zros_node('zros_side')
    got: list[str] = []
    listener = sdk.ROS2Subscriber(
        '/chatter', String, callback=lambda m: got.append(m.data), router_port=sdk.port,
        node_name='sdk_listener',
    )  # fmt: skip
    publisher = sdk.ROS2Publisher('/back', String, router_port=sdk.port, node_name='sdk_talker')
    try:
        pub = node.create_publisher(String, 'chatter')
        assert pub.wait_for_subscribers()
        pub.write(zros.Message(String, data='zros to sdk'))
        assert wait_for(lambda: got == ['zros to sdk'])
        sub = node.create_subscription(String, 'back')
        assert publisher.keyexpr == sub.key  # the same key, built independently
        assert node.wait_for_publishers('/back')

        def delivered() -> bool:
            publisher.publish(data='sdk to zros')  # until the route is up
            return sub.has_new_message()

        assert wait_for(delivered)
        assert sub.read_message().data == 'sdk to zros' and sub.unattached == 0
    finally:
        listener.close()
        publisher.close()


def test_sdk_services_both_ways(sdk: Any, zros_node: Callable[..., Node]) -> None:
    node = zros_node('zros_side')
    service = node.create_service(ADD, 'add', lambda r: service.Response(sum=r.a + r.b))
    holder: dict[str, Any] = {}
    server = sdk.ROS2ServiceServer(
        '/mul', ADD, callback=lambda r: holder['server'].response_msg_class(sum=r.a * r.b),
        router_port=sdk.port, node_name='sdk_server',
    )  # fmt: skip
    holder['server'] = server
    client = sdk.ROS2ServiceClient('/add', ADD, router_port=sdk.port, node_name='sdk_client')
    try:
        assert client.keyexpr == service.key
        with spinning(node):
            response = client.call(a=2, b=40)
            assert response is not None and response.sum == 42
        zros_client = node.create_client(ADD, 'mul')
        assert zros_client.wait_for_service()
        assert zros_client.call(a=6, b=7).sum == 42
        assert zros_client.call_async(a=3, b=3).result(5).sum == 9
    finally:
        client.close()
        server.close()


def test_sdk_and_zros_list_each_other(sdk: Any, zros_node: Callable[..., Node]) -> None:
    node = zros_node('zros_side', '/robot')
    node.create_publisher(String, 'status')
    node.create_service(ADD, 'add', lambda r: None)
    publisher = sdk.ROS2Publisher('/sdk_chatter', String, router_port=sdk.port, node_name='sdk')
    try:
        graph = node.graph
        assert graph.wait_until(lambda: '/sdk_chatter' in graph.topics(), timeout=5)
        assert graph.topics()['/sdk_chatter'] == [String]
        assert '/sdk' in graph.nodes()
        topics = dict(sdk.get_topic_names_and_types(router_port=sdk.port, timeout=2))
        assert topics['/robot/status'] == [String]
        services = dict(sdk.get_service_names_and_types(router_port=sdk.port, timeout=2))
        assert services['/robot/add'] == [ADD]
    finally:
        publisher.close()


def test_sdk_departures_from_the_spec(
    sdk: Any, zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    """Spec §10: its GIDs are random, not the XXH3 of the token (so a GID in a message does not
    match the one in the graph); its publisher numbers from 0; its QoS strings spell values that
    equal rmw_zenoh's defaults; it hashes .msg ``char`` as CHAR. zros follows the spec in each
    case."""
    observer = zros_transport()
    publisher = sdk.ROS2Publisher('/numbers', String, router_port=sdk.port, node_name='sdk_pub')
    node = zros_node('zros_pub')
    ours = node.create_publisher(String, 'numbers')
    samples, raw = capture(observer, ours.key)
    try:

        def publisher_tokens(node_name: str) -> list[str]:
            tokens = tokens_of(observer, node_name)
            return [t for t in tokens if '/MP/' in t and '/%numbers/' in t]

        # the node's own token can arrive before its publisher's: wait for the publishers'
        assert wait_for(lambda: publisher_tokens('sdk_pub') and publisher_tokens('zros_pub'))
        (sdk_token,) = publisher_tokens('sdk_pub')
        (zros_token,) = publisher_tokens('zros_pub')

        def both_sent() -> bool:
            publisher.publish(data='sdk')
            ours.write(zros.Message(String, data='zros'))
            return {s.payload.to_bytes()[8:-1] for s in samples} >= {b'sdk', b'zros'}

        assert wait_for(both_sent)
    finally:
        raw.undeclare()
        publisher.close()
    first = {
        s.payload.to_bytes()[8:-1]: Attachment.decode(s.attachment.to_bytes())
        for s in reversed(samples)
    }
    assert first[b'zros'].gid == gid(zros_token) == ours.gid
    assert first[b'zros'].sequence_number == 1
    assert first[b'sdk'].gid != gid(sdk_token)  # random: the spec derives it from the token
    assert first[b'sdk'].sequence_number == 0  # the spec starts at 1
    assert parse_token(sdk_token).node.name == 'sdk_pub'
    # QoS strings: it spells values equal to rmw_zenoh's defaults (spec §3.2 leaves them empty);
    # rmw_zenoh and zros read both forms, zros writes the spec's
    from zenoh_ros2_sdk import qos

    lease = qos.QosProfile(history_depth=10, liveliness_lease_duration=qos.Duration(2, 500000000))
    for theirs, spec in (
        (qos.QosProfile(history_depth=42).encode(), '::,:,:,:,,'),
        (lease.encode(), '::,10:,:,:,2,500000000'),
    ):
        assert theirs != spec
        assert RmwQoS.parse(theirs) == RmwQoS.parse(spec)
        assert RmwQoS.parse(theirs).format() == spec
    from zenoh_ros2_sdk.utils import get_type_hash

    char = 'std_msgs/msg/Char'
    assert get_type_hash(char, msg_definition='char data') != type_hash(default_registry(), char)


# --- pyzeros ------------------------------------------------------------------------------------


@pytest.fixture
def pyzeros(zros_router: Router, monkeypatch: pytest.MonkeyPatch) -> Iterator[ModuleType]:
    """pyzeros on a Zenoh session of its own (a client of the test router)."""
    monkeypatch.setenv('ROS_DISTRO', 'jazzy')  # its types would otherwise guess (spec §10)
    module = pytest.importorskip(
        'pyzeros', reason='pyzeros is not installed (pip install -e .[test])'
    )
    settings = {
        'mode': 'client',
        'connect': {'endpoints': [zros_router.endpoint]},
        'scouting': {'multicast': {'enabled': False}},
        'transport': {'shared_memory': {'enabled': False}},
    }
    session = zenoh.open(zenoh.Config.from_json5(json.dumps(settings)))
    module.zenoh_session = session  # type: ignore[attr-defined]
    try:
        yield module
    finally:
        session.close()


def pyzeros_types() -> tuple[Any, Any]:
    from ros2_pyterfaces.cyclone import all_msgs, all_srvs

    return all_msgs.String, all_srvs.SetBool


def test_pyzeros_topics_both_ways(pyzeros: Any, zros_node: Callable[..., Node]) -> None:
    StringMsg, _ = pyzeros_types()
    assert StringMsg.hash_rihs01() == type_hash(default_registry(), String)
    node = zros_node('zros_side')

    async def exchange() -> tuple[Any, Any]:
        with pyzeros.auto_context(node='pz_node', zenoh_session=pyzeros.zenoh_session):
            sub = pyzeros.Sub(StringMsg, 'chatter')
            pub = node.create_publisher(String, 'chatter')
            assert pub.wait_for_subscribers()
            pub.write(zros.Message(String, data='zros to pyzeros'))
            received = await asyncio.wait_for(sub.wait_for_new(), 5)
            zros_sub = node.create_subscription(String, 'back')
            their_pub = pyzeros.Pub(StringMsg, 'back')
            assert their_pub.publisher_keyexpr == zros_sub.key
            for _ in range(100):  # until the route is up
                their_pub.publish(StringMsg(data='pyzeros to zros'))
                if await asyncio.to_thread(zros_sub.wait_for_message, 0.05):
                    break
            return received, zros_sub

    received, zros_sub = asyncio.run(exchange())
    assert received.data == 'zros to pyzeros'
    assert zros_sub.received >= 1 and zros_sub.unattached == 0


def test_pyzeros_services_both_ways(pyzeros: Any, zros_node: Callable[..., Node]) -> None:
    _, SetBool = pyzeros_types()
    assert SetBool.hash_rihs01() == type_hash(default_registry(), SET_BOOL)
    node = zros_node('zros_side')
    service = node.create_service(
        SET_BOOL, 'toggle', lambda r: service.Response(success=r.data, message='zros')
    )

    async def exchange() -> tuple[Any, Any]:
        with pyzeros.auto_context(node='pz_node', zenoh_session=pyzeros.zenoh_session):
            client = pyzeros.Client(SetBool, 'toggle')
            await asyncio.wait_for(client.wait_for_service(), 5)
            theirs = await asyncio.wait_for(client.call_async(SetBool.Request(data=True)), 5)
            server = pyzeros.Server(SetBool, 'pz_toggle')

            async def serve() -> None:
                async for responder in server.listen_reliable():
                    responder.response.success = not responder.request.data
                    responder.response.message = 'pyzeros'
                    responder.send()

            task = asyncio.create_task(serve())
            zros_client = node.create_client(SET_BOOL, 'pz_toggle')
            assert await asyncio.to_thread(zros_client.wait_for_service)
            ours = await asyncio.wait_for(zros_client.call_async(data=True), 5)
            task.cancel()
            return theirs, ours

    with spinning(node):
        theirs, ours = asyncio.run(exchange())
    assert (theirs.success, theirs.message) == (True, 'zros')
    assert (ours.success, ours.message) == (False, 'pyzeros')


def test_pyzeros_in_the_zros_graph_and_its_numbering(
    pyzeros: Any, zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    """pyzeros derives GIDs as the spec says (it agrees with zros), but numbers publications and
    requests from 0 where the spec starts at 1 (zros servers accept 0: it is not negative).
    pyzeros has no graph listing of its own."""
    StringMsg, _ = pyzeros_types()
    node = zros_node('zros_side')
    observer = zros_transport()

    def numbers(samples: list[Any]) -> list[int]:
        return [Attachment.decode(s.attachment.to_bytes()).sequence_number for s in samples]

    async def run() -> tuple[list[Any], str, int]:
        with pyzeros.auto_context(node='pz_node', zenoh_session=pyzeros.zenoh_session):
            pub = pyzeros.Pub(StringMsg, 'pz_topic')
            samples, raw = capture(observer, pub.publisher_keyexpr)
            graph = node.graph
            assert await asyncio.to_thread(
                graph.wait_until, lambda: '/pz_topic' in graph.topics(), 5
            )
            assert '/pz_node' in graph.nodes()
            published = 0
            for _ in range(100):  # until the capture is matched: the first may go unseen
                pub.publish(StringMsg(data='n'))
                published += 1
                if await asyncio.to_thread(wait_for, lambda: samples, 0.05):
                    break
            pub.publish(StringMsg(data='n'))  # seen: its number tells where numbering starts
            published += 1
            assert await asyncio.to_thread(
                wait_for, lambda: max(numbers(samples)) >= published - 1, 5
            )
            raw.undeclare()
            return samples, pub.token_keyexpr, published

    samples, token, published = asyncio.run(run())
    first = Attachment.decode(samples[0].attachment.to_bytes())
    assert max(numbers(samples)) == published - 1  # from 0: the spec (and zros) start at 1
    assert first.gid == gid(token)  # the spec's GID: pyzeros and zros agree
    (endpoint,) = node.graph.publishers(node.scheme.key('/pz_topic'))
    assert endpoint.gid == first.gid and endpoint.node == '/pz_node'
