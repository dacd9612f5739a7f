"""The live graph view: bridge-shaped tokens from other processes, bridges, zros nodes."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable, Iterator

import pytest

from zros.graph import Graph, graph_of
from zros.keyexpr.kinds import EntityKind
from zros.node import Node
from zros.qos import QoS, Reliability
from zros.transport import Router, Transport

ANNOUNCER = """
import sys, json, zenoh
endpoint, zid_out = sys.argv[1], sys.argv[2:]
config = zenoh.Config.from_json5(json.dumps({'mode': 'client', 'connect': {'endpoints': [endpoint]},
    'scouting': {'multicast': {'enabled': False}}}))
session = zenoh.open(config)
zid = str(session.zid())
tokens = [session.liveliness().declare_token(t.replace('ZID', zid)) for t in [
    '@/ZID/@ros2_lv/MP/bot1\u00a7turtle1\u00a7cmd_vel/geometry_msgs\u00a7msg\u00a7Twist/:1:0:0,10',
    '@/ZID/@ros2_lv/MS/bot1\u00a7turtle1\u00a7pose/turtlesim\u00a7msg\u00a7Pose/:0:0:0,5',
    '@/ZID/@ros2_lv/SS/bot1\u00a7clear/std_srvs\u00a7srv\u00a7Empty',
    '@/ZID/@ros2_lv/AS/bot1\u00a7turtle1\u00a7rotate_absolute/turtlesim\u00a7action\u00a7RotateAbsolute',
    '@/ZID/@ros2_lv/XX/not/a/token',
]]
print(zid, flush=True)
if sys.stdin.readline().strip() == 'kill':
    import os; os.kill(os.getpid(), 9)
session.close()
"""


@pytest.fixture
def announcer(zros_router: Router) -> Iterator[subprocess.Popen[str]]:
    process = subprocess.Popen(
        [sys.executable, '-c', ANNOUNCER, zros_router.endpoint],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
        process.communicate(timeout=10)


def test_entities_of_another_process_appear_and_go_within_100_ms(
    zros_transport: Callable[..., Transport], announcer: subprocess.Popen[str]
) -> None:
    graph: Graph = graph_of(zros_transport())
    assert announcer.stdout is not None and announcer.stdin is not None
    zid = announcer.stdout.readline().strip()
    announced = time.perf_counter()
    assert graph.wait_until(lambda: len(graph.endpoints()) == 4, timeout=5)
    assert time.perf_counter() - announced < 0.1
    topics = graph.topics('/bot1')
    assert topics == {
        '/turtle1/cmd_vel': ['geometry_msgs/msg/Twist'],
        '/turtle1/pose': ['turtlesim/msg/Pose'],
    }
    assert graph.services('/bot1') == {'/clear': ['std_srvs/srv/Empty']}
    assert graph.actions('/bot1') == {
        '/turtle1/rotate_absolute': ['turtlesim/action/RotateAbsolute']
    }
    (publisher,) = graph.publishers('bot1/turtle1/cmd_vel')
    assert publisher.zid == zid and publisher.is_bridged and publisher.qos == QoS(10)
    (subscriber,) = graph.subscribers('bot1/turtle1/pose')
    assert subscriber.qos == QoS(5, Reliability.BEST_EFFORT)
    assert graph.topics('/') == {'/bot1/turtle1/cmd_vel': ['geometry_msgs/msg/Twist'],
                                 '/bot1/turtle1/pose': ['turtlesim/msg/Pose']}  # fmt: skip
    announcer.stdin.write('exit\n')
    announcer.stdin.flush()
    assert announcer.wait(10) == 0
    exited = time.perf_counter()
    assert graph.wait_until(lambda: not graph.endpoints(), timeout=5)
    assert time.perf_counter() - exited < 0.1


def test_a_killed_process_leaves_the_graph(
    zros_transport: Callable[..., Transport], announcer: subprocess.Popen[str]
) -> None:
    graph: Graph = graph_of(zros_transport())
    assert announcer.stdout is not None and announcer.stdin is not None
    announcer.stdout.readline()
    assert graph.wait_until(lambda: len(graph.endpoints()) == 4, timeout=5)
    announcer.stdin.write('kill\n')
    announcer.stdin.flush()
    announcer.wait(10)
    assert graph.wait_until(lambda: not graph.endpoints(), timeout=15)


FAKE_BRIDGE = """
import sys, json, threading, zenoh
endpoint, namespace, version = sys.argv[1:4]
config = zenoh.Config.from_json5(json.dumps({'mode': 'client', 'connect': {'endpoints': [endpoint]},
    'scouting': {'multicast': {'enabled': False}}}))
session = zenoh.open(config)
zid = str(session.zid())
def answer(query):
    item = str(query.key_expr).split('/')[-1]
    with query:
        if item == 'version':
            query.reply(f'@/{zid}/ros2/version', json.dumps('v' + version))
        elif item == 'config':
            query.reply(f'@/{zid}/ros2/config', json.dumps({'namespace': namespace, 'nodename': 'bridge_one'}))
admin = session.declare_queryable(f'@/{zid}/ros2/**', answer)
token = session.liveliness().declare_token(f'@/{zid}/@ros2_lv')
print(zid, flush=True)
sys.stdin.readline()
session.close()
"""


def wait_for_bridge(transport: Transport, version: str) -> None:
    """Until the fake bridge answers its admin queries through the router (declarations travel
    on their own: the printed zid only says they were made)."""
    graph = graph_of(transport)
    assert graph.wait_until(
        lambda: [b for b in graph.bridges() if b.version == version], timeout=30
    ), graph.bridges()


def test_bridges_their_version_namespace_and_node(
    zros_router: Router, zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    bridge = subprocess.Popen(
        [sys.executable, '-c', FAKE_BRIDGE, zros_router.endpoint, '/bot1', '1.10.0'],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert bridge.stdout is not None and bridge.stdin is not None
        zid = bridge.stdout.readline().strip()
        wait_for_bridge(zros_transport(), '1.10.0')
        node = zros_node('laptop')  # bridge_namespace not given: learnt from the bridge
        assert node.scheme.namespace == '/bot1'
        assert node.scheme.send_type_hash  # 1.10.0 takes the typehash QoS field
        graph = node.graph
        assert graph.wait_until(lambda: graph.bridges() and graph.bridges()[0].version, timeout=5)
        (info,) = graph.bridges()
        assert (info.zid, info.version, info.namespace, info.version_tuple) == (
            zid, '1.10.0', '/bot1', (1, 10, 0),
        )  # fmt: skip
        assert '/bot1/bridge_one' in node.get_node_names()
        pub = node.create_publisher('std_msgs/msg/String', 'chatter')
        assert pub.key == 'bot1/chatter'
        assert 'typehash=RIHS01_df668c74' in pub._tokens[-1]
        explicit = zros_node('explicit', bridge_namespace='/')
        assert explicit.scheme.namespace == '/'
        bridge.stdin.write('bye\n')
        bridge.stdin.flush()
        assert bridge.wait(10) == 0
        assert graph.wait_until(lambda: not graph.bridges(), timeout=5)
    finally:
        if bridge.poll() is None:
            bridge.kill()


def test_old_bridges_get_no_type_hash(
    zros_router: Router, zros_node: Callable[..., Node], zros_transport: Callable[..., Transport]
) -> None:
    bridge = subprocess.Popen(
        [sys.executable, '-c', FAKE_BRIDGE, zros_router.endpoint, '/', '1.0.3'],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert bridge.stdout is not None
        bridge.stdout.readline()
        wait_for_bridge(zros_transport(), '1.0.3')
        node = zros_node('careful')
        assert not node.scheme.send_type_hash
        assert node.create_publisher('std_msgs/msg/String', 'x')._tokens[-1].endswith(':1:0:0,10')
    finally:
        bridge.kill()
        bridge.communicate()


def test_zros_nodes_by_name_and_what_they_own(zros_node: Callable[..., Node]) -> None:
    talker = zros_node('talker', '/robot')
    viewer = zros_node('viewer')
    talker.create_publisher('std_msgs/msg/String', 'chatter')
    talker.create_subscription('geometry_msgs/msg/Twist', 'cmd_vel', qos='sensor_data')
    graph = viewer.graph
    topics = {(EntityKind.PUBLISHER, 'robot/chatter', 'std_msgs/msg/String'),
              (EntityKind.SUBSCRIBER, 'robot/cmd_vel', 'geometry_msgs/msg/Twist')}  # fmt: skip
    parameters = {(EntityKind.PUBLISHER, 'parameter_events', 'rcl_interfaces/msg/ParameterEvent')}
    parameters |= {
        (EntityKind.SERVICE_SERVER, f'robot/talker/{name}', f'rcl_interfaces/srv/{kind}')
        for name, kind in (
            ('list_parameters', 'ListParameters'),
            ('get_parameters', 'GetParameters'),
            ('set_parameters', 'SetParameters'),
            ('set_parameters_atomically', 'SetParametersAtomically'),
            ('get_parameter_types', 'GetParameterTypes'),
            ('describe_parameters', 'DescribeParameters'),
        )
    }

    def owned() -> set[tuple[EntityKind, str, str]]:
        return {(e.kind, e.key, e.type_name) for e in graph.node_endpoints('/robot/talker')}

    assert graph.wait_until(lambda: owned() == topics | parameters, timeout=5), owned()
    assert graph.wait_until(lambda: {'/robot/talker', '/viewer'} <= set(viewer.get_node_names()))
    assert ('/robot/chatter', ['std_msgs/msg/String']) in viewer.get_topic_names_and_types()
    assert viewer.count_publishers('/robot/chatter') == 1
    assert viewer.count_subscribers('/robot/cmd_vel') == 1
    talker.destroy()
    assert graph.wait_until(lambda: '/robot/talker' not in viewer.get_node_names(), timeout=5)
    assert graph.wait_until(lambda: viewer.count_publishers('/robot/chatter') == 0, timeout=5)


@pytest.mark.parametrize('zros_wire', ['bridge', 'rmw_zenoh'])
def test_a_nodes_own_entities_are_in_its_graph_at_once(zros_node: Callable[..., Node]) -> None:
    # as in rclpy: no wait between making a publisher and seeing it in the node's own graph
    node = zros_node('seer')
    for _ in range(20):
        publisher = node.create_publisher('std_msgs/msg/String', 'mine')
        subscriber = node.create_subscription('std_msgs/msg/String', 'theirs')
        assert node.count_publishers('/mine') == 1
        assert node.count_subscribers('/theirs') == 1
        assert '/mine' in dict(node.get_topic_names_and_types())
        node.destroy_publisher(publisher)
        node.destroy_subscription(subscriber)
        assert node.count_publishers('/mine') == 0  # and gone at once
        assert node.count_subscribers('/theirs') == 0


def test_waiting_for_publishers_and_subscribers(zros_node: Callable[..., Node]) -> None:
    viewer = zros_node('viewer')
    assert not viewer.wait_for_publishers('late', timeout=0.1)
    other = zros_node('other')
    other.create_publisher('std_msgs/msg/String', 'late')
    assert viewer.wait_for_publishers('late', timeout=5)
    assert not viewer.wait_for_subscribers('late', timeout=0.1)
    other.create_subscription('std_msgs/msg/String', 'late')
    assert viewer.wait_for_subscribers('late', timeout=5)
