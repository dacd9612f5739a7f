"""Topics between zros and real ROS 2 (rclpy, Fast DDS) through a zenoh-bridge-ros2dds.

By default the bridge is the stand-in of ``bridge_standin`` in a private network namespace (see
``rig.py``); with ``ZROS_INTEROP_BRIDGE`` set it is a real bridge (``docker/``). Messages are
random (hypothesis), serialized by rclpy (rosidl + Fast CDR) on the ROS side and compared field
by field as rclpy messages and as zros messages.

Run more examples with ``ZROS_INTEROP_EXAMPLES=10 pytest tests/interop/test_topics.py``.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest

pytest.importorskip(
    'rclpy.serialization',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)

import zenoh
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

import zros
from tests.cdr.strategies import message_strategy
from tests.interop import rig
from tests.interop.bridge_standin import protocol as p
from tests.interop.conftest import Interop, TrackedWorker
from tests.interop.rclpy_support import make_registry, rclpy_class, to_rclpy
from zros.cdr import decode, encode
from zros.testing import wait_for

REGISTRY = make_registry()
EXAMPLES = int(os.environ.get('ZROS_INTEROP_EXAMPLES', '2'))
#: messages per example (each zros subscriber below keeps 10)
BATCH = 3
TIMEOUT = rig.DEADLINE

TYPES = [
    'std_msgs/msg/String',
    'sensor_msgs/msg/Imu',
    'sensor_msgs/msg/Image',
    'sensor_msgs/msg/PointCloud2',
    'test_msgs/msg/Arrays',
    'test_msgs/msg/BoundedSequences',
]

interop_examples = settings(
    max_examples=EXAMPLES,
    deadline=None,
    database=None,
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[
        HealthCheck.function_scoped_fixture,
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
    ],
)

Bridge = rig.BridgeUnderTest
MakeNode = Callable[..., Any]


def cls(name: str) -> Any:
    return REGISTRY.get_class(name)


def rclpy_bytes(name: str, message: Any) -> bytes:
    """What an rclpy publisher of ``message`` sends: rosidl serialization, CDR header included."""
    return bytes(serialize_message(to_rclpy(REGISTRY, name, message)))


def assert_received_by_ros(name: str, sent: list[Any], received: list[bytes]) -> None:
    """rclpy and zros both read back what zros sent, and the bytes crossed unchanged (§2)."""
    assert len(received) == len(sent), f'{len(received)} of {len(sent)} messages arrived'
    for message, data in zip(sent, received, strict=True):
        assert deserialize_message(data, rclpy_class(name)) == to_rclpy(REGISTRY, name, message)
        assert decode(cls(name), data) == message
        assert_same_cdr(encode(message), data)


def assert_same_cdr(sent: bytes, received: bytes) -> None:
    """The same serialized message up to DDS padding: Fast DDS pads samples to 4 bytes with
    zeros; CycloneDDS also writes the pad count in the low bits of header byte 3 (§2)."""
    assert received[:3] == sent[:3]
    assert received[3] & ~3 == sent[3] & ~3
    assert received[4 : len(sent)] == sent[4:]
    tail = received[len(sent) :]
    assert len(tail) < 4 and not any(tail), f'{len(tail)} bytes after the message: {tail.hex()}'


def take_all(subscription: Any, count: int, timeout: float = TIMEOUT) -> list[Any]:
    messages: list[Any] = []
    assert wait_for(lambda: messages.extend(subscription.take()) or len(messages) >= count, timeout)
    return messages


@pytest.fixture
def raw_session(interop_bridge: Bridge) -> Iterator[Any]:
    """A plain Zenoh client session to the bridge (what a zros mistake would look like)."""
    config = {
        'mode': 'client',
        'connect': {'endpoints': [interop_bridge.endpoint]},
        'scouting': {'multicast': {'enabled': False}},
        'transport': {'shared_memory': {'enabled': False}},
    }
    session = zenoh.open(zenoh.Config.from_json5(json.dumps(config)))
    yield session
    session.close()


def admin_get(session: Any, selector: str) -> dict[str, Any]:
    return {
        str(reply.ok.key_expr): json.loads(reply.ok.payload.to_string())
        for reply in session.get(selector, timeout=5.0)
        if reply.ok is not None
    }


# --- random messages of the required types, both ways ---------------------------------------


def ros_to_zros(ix: Interop, topic: str, name: str, messages: list[Any]) -> None:
    ros = ix.ros
    node = ix.node()
    try:
        subscription = node.create_subscription(name, topic, qos=10)
        publisher = ros.publisher(topic, name)
        assert ros.wait_subscribers(publisher, timeout=TIMEOUT) >= 1
        ros.publish(publisher, [rclpy_bytes(name, m) for m in messages])
        assert take_all(subscription, len(messages)) == messages
        ros.destroy(publisher)
    finally:
        node.destroy()


def zros_to_ros(ix: Interop, topic: str, name: str, messages: list[Any]) -> None:
    ros = ix.ros
    node = ix.node()
    try:
        publisher = node.create_publisher(name, topic, 10)
        subscription = ros.subscription(topic, name)
        assert publisher.wait_for_subscribers(TIMEOUT)
        # the bridge's route exists; its DDS writer must also have matched the ROS reader
        assert ros.wait_publishers(subscription) >= 1
        for message in messages:
            publisher.write(message)
        received = ros.wait_messages(subscription, len(messages), timeout=TIMEOUT)
        if len(received) != len(messages):  # say what the bridge did, not only what is missing
            sent = [encode(message)[4:] for message in messages]
            which = [
                i for i, data in enumerate(sent) if any(r[4:].startswith(data) for r in received)
            ]
            pytest.fail(
                f'{len(received)} of {len(messages)} messages arrived (those sent as {which}); '
                f'the stand-in log ends with:\n{ix.standin_log()}'
            )
        assert_received_by_ros(name, messages, received)
        ros.destroy(subscription)
    finally:
        node.destroy()


@pytest.mark.parametrize('name', TYPES)
@interop_examples
@given(data=st.data())
def test_ros_publisher_to_zros_subscriber(name: str, data: Any, interop: Interop) -> None:
    strategy = message_strategy(REGISTRY, name)
    messages = data.draw(st.lists(strategy, min_size=BATCH, max_size=BATCH), label='messages')
    topic = interop.topic(name.rpartition('/')[2].lower())
    ros_to_zros(interop, topic, name, messages)


@pytest.mark.parametrize('name', TYPES)
@interop_examples
@given(data=st.data())
def test_zros_publisher_to_ros_subscriber(name: str, data: Any, interop: Interop) -> None:
    strategy = message_strategy(REGISTRY, name)
    messages = data.draw(st.lists(strategy, min_size=BATCH, max_size=BATCH), label='messages')
    topic = interop.topic(name.rpartition('/')[2].lower())
    zros_to_ros(interop, topic, name, messages)


def big_image(rng: np.random.Generator) -> Any:
    """A 640x480 rgb8 image of random pixels."""
    header = cls('std_msgs/msg/Header')(
        stamp=cls('builtin_interfaces/msg/Time')(
            sec=int(rng.integers(0, 2**31)), nanosec=int(rng.integers(0, 10**9))
        ),
        frame_id='camera_optical',
    )
    return cls('sensor_msgs/msg/Image')(
        header=header,
        height=480,
        width=640,
        encoding='rgb8',
        is_bigendian=0,
        step=640 * 3,
        data=rng.integers(0, 256, 640 * 480 * 3, dtype=np.uint8),
    )


def point_cloud(rng: np.random.Generator, points: int) -> Any:
    """An unorganised xyz + intensity cloud (float32 each) of random points."""
    field = cls('sensor_msgs/msg/PointField')
    fields = [field(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate('xyzi')]
    values = rng.standard_normal(points * 4).astype('<f4')
    return cls('sensor_msgs/msg/PointCloud2')(
        header=cls('std_msgs/msg/Header')(frame_id='lidar'),
        height=1,
        width=points,
        fields=fields,
        is_bigendian=False,
        point_step=16,
        row_step=16 * points,
        data=np.frombuffer(values.tobytes(), np.uint8).copy(),
        is_dense=True,
    )


def test_image_640x480_both_ways(interop: Interop) -> None:
    rng = np.random.default_rng(640480)
    images = [big_image(rng) for _ in range(2)]
    name = 'sensor_msgs/msg/Image'
    ros_to_zros(interop, interop.topic('camera'), name, images)
    zros_to_ros(interop, interop.topic('camera'), name, images)


def test_point_cloud_both_ways(interop: Interop) -> None:
    rng = np.random.default_rng(2)
    clouds = [point_cloud(rng, n) for n in (1, 1000, 20000)]
    name = 'sensor_msgs/msg/PointCloud2'
    ros_to_zros(interop, interop.topic('points'), name, clouds)
    zros_to_ros(interop, interop.topic('points'), name, clouds)


def test_sensor_data_qos_both_ways(interop: Interop) -> None:
    """Best-effort ROS publishers reach a best-effort zros subscriber, and the other way."""
    name = 'sensor_msgs/msg/Imu'
    imu = cls(name)(header=cls('std_msgs/msg/Header')(frame_id='imu'))
    imu.linear_acceleration.z = 9.81
    best_effort = rig.qos_spec(5, reliability='best_effort')
    node = interop.node()

    topic = interop.topic('imu')
    subscription = node.create_subscription(name, topic, qos='sensor_data')
    publisher = interop.ros.publisher(topic, name, best_effort)
    assert interop.ros.wait_subscribers(publisher) >= 1
    # best effort may drop: repeat until one arrives
    data = rclpy_bytes(name, imu)
    assert wait_for(
        lambda: interop.ros.publish(publisher, [data]) or subscription.has_new_message(),
        TIMEOUT,
    )
    assert subscription.read_message() == imu

    topic = interop.topic('imu')
    zros_publisher = node.create_publisher(name, topic, 'sensor_data')
    ros_subscription = interop.ros.subscription(topic, name, best_effort)
    assert zros_publisher.wait_for_subscribers(TIMEOUT)
    assert wait_for(
        lambda: (
            zros_publisher.write(imu)
            or interop.ros.wait_messages(ros_subscription, 1, timeout=0.05)
        ),
        TIMEOUT,
    )
    assert deserialize_message(
        interop.ros.wait_messages(ros_subscription)[0], rclpy_class(name)
    ) == to_rclpy(REGISTRY, name, imu)


# --- the ROS graph ------------------------------------------------------------------------------


def test_zros_topics_appear_in_the_ros_graph(interop: Interop) -> None:
    node = interop.node()
    published, subscribed = interop.topic('graph_pub'), interop.topic('graph_sub')
    publisher = node.create_publisher('test_msgs/msg/Arrays', published, 10)
    subscription = node.create_subscription('sensor_msgs/msg/Imu', subscribed, qos=10)

    topics = interop.ros.wait_topic(published, 'test_msgs/msg/Arrays')
    assert topics.get(published) == ['test_msgs/msg/Arrays']
    topics = interop.ros.wait_topic(subscribed, 'sensor_msgs/msg/Imu')
    assert topics.get(subscribed) == ['sensor_msgs/msg/Imu']

    publisher.close()
    assert published not in interop.ros.wait_topic(published, 'test_msgs/msg/Arrays', present=False)
    subscription.close()
    assert subscribed not in interop.ros.wait_topic(
        subscribed, 'sensor_msgs/msg/Imu', present=False
    )


def test_zros_node_namespace_and_private_names(interop: Interop) -> None:
    """zros resolves relative and ``~`` names itself; the bridge adds only its own namespace."""
    stem = interop.topic('rel')[1:]
    node = interop.node('talker', namespace='/robot')
    node.create_publisher('std_msgs/msg/String', stem, 10)
    node.create_publisher('std_msgs/msg/String', f'~/{stem}', 10)
    interop.ros.wait_topic(f'/robot/{stem}', 'std_msgs/msg/String')
    topics = interop.ros.wait_topic(f'/robot/talker/{stem}', 'std_msgs/msg/String')
    assert topics[f'/robot/{stem}'] == ['std_msgs/msg/String']


# --- transient local (/tf_static style) ---------------------------------------------------------


def transform(rng: np.random.Generator, child: str) -> Any:
    message = cls('geometry_msgs/msg/TransformStamped')(
        header=cls('std_msgs/msg/Header')(frame_id='base_link'), child_frame_id=child
    )
    message.transform.translation.x, message.transform.translation.y = rng.standard_normal(2)
    message.transform.rotation.w = 1.0
    return message


LATCHED_ROS = rig.qos_spec(1, durability='transient_local')


def test_latched_ros_publisher_reaches_late_zros_subscribers(interop: Interop) -> None:
    name = 'geometry_msgs/msg/TransformStamped'
    topic = interop.topic('tf_static')
    message = transform(np.random.default_rng(1), 'laser')
    publisher = interop.ros.publisher(topic, name, LATCHED_ROS)
    interop.ros.publish(publisher, [rclpy_bytes(name, message)])

    first = interop.node('first').create_subscription(name, topic, qos='latched')
    assert first.wait_for_message(TIMEOUT) == message
    # the second one gets it from the bridge's cache (AdvancedPublisher, §7)
    second = interop.node('second').create_subscription(name, topic, qos='latched')
    assert second.wait_for_message(TIMEOUT) == message
    assert first.take() == []


def test_latched_zros_publisher_reaches_late_ros_subscribers(interop: Interop) -> None:
    name = 'geometry_msgs/msg/TransformStamped'
    topic = interop.topic('tf_static')
    message = transform(np.random.default_rng(2), 'camera')
    publisher = interop.node().create_publisher(name, topic, 'latched')
    publisher.write(message)

    first = interop.ros.subscription(topic, name, LATCHED_ROS)
    assert_received_by_ros(name, [message], interop.ros.wait_messages(first, timeout=TIMEOUT))
    # the second one gets it from the bridge's transient-local DDS writer
    second = interop.ros.subscription(topic, name, LATCHED_ROS)
    assert_received_by_ros(name, [message], interop.ros.wait_messages(second, timeout=TIMEOUT))


def test_latched_history_depth_both_ways(interop: Interop) -> None:
    """A transient-local keep-last 3 publisher: a late subscriber gets the last 3, in order."""
    name = 'std_msgs/msg/String'
    qos = zros.QoS(3, durability=zros.Durability.TRANSIENT_LOCAL)
    messages = [zros.Message(name, data=f'latched {i}') for i in range(5)]
    node = interop.node()

    topic = interop.topic('history')
    publisher = node.create_publisher(name, topic, qos)
    for message in messages:
        publisher.write(message)
    subscription = interop.ros.subscription(
        topic, name, rig.qos_spec(3, durability='transient_local')
    )
    received = interop.ros.wait_messages(subscription, 3, timeout=TIMEOUT)
    assert_received_by_ros(name, messages[-3:], received)

    topic = interop.topic('history')
    ros_publisher = interop.ros.publisher(
        topic, name, rig.qos_spec(3, durability='transient_local')
    )
    interop.ros.publish(ros_publisher, [rclpy_bytes(name, m) for m in messages])
    late = node.create_subscription(name, topic, qos=qos)
    assert take_all(late, 3) == messages[-3:]


# --- a bridge with a namespace ------------------------------------------------------------------


def test_namespaced_bridge(
    bot1_bridge: Bridge,
    zros_nodes: MakeNode,
    unique_topic: Callable[[str], str],
) -> None:
    """Behind ``namespace: /bot1`` ROS names stay as they are; Zenoh keys get ``bot1/``."""
    worker = TrackedWorker(bot1_bridge.new_worker())
    try:
        name = 'std_msgs/msg/String'
        node = zros_nodes(bot1_bridge, bridge_namespace='/bot1')
        message = zros.Message(name, data='hello bot1')

        topic = unique_topic('ns_down')
        publisher = node.create_publisher(name, topic, 10)
        topics = worker.wait_topic(topic, name)
        assert f'/bot1{topic}' not in topics
        subscription = worker.subscription(topic, name)
        assert publisher.wait_for_subscribers(TIMEOUT)
        assert worker.wait_publishers(subscription) >= 1
        publisher.write(message)
        assert_received_by_ros(name, [message], worker.wait_messages(subscription))

        topic = unique_topic('ns_up')
        zros_subscription = node.create_subscription(name, topic, qos=10)
        # a plain Zenoh subscriber on the prefixed key sees the same samples
        raw: list[bytes] = []
        key = 'bot1' + topic
        plain = node.transport.session.declare_subscriber(
            key, lambda sample: raw.append(sample.payload.to_bytes())
        )
        ros_publisher = worker.publisher(topic, name)
        assert worker.wait_subscribers(ros_publisher) >= 1
        worker.publish(ros_publisher, [rclpy_bytes(name, message)])
        assert zros_subscription.wait_for_message(TIMEOUT) == message
        assert wait_for(lambda: len(raw) == 1, TIMEOUT)
        assert_same_cdr(rclpy_bytes(name, message), raw[0])
        plain.undeclare()
    finally:
        worker.cleanup()
        worker.close()


def test_namespaced_standin_maps_keys_like_the_bridge(bot1_bridge: Bridge) -> None:
    """§1: a key without the ``bot1`` prefix keeps its whole name (and the route listens on the
    prefixed key, so no data would flow); ``bot10/x`` hits the plain string prefix test."""
    local = bot1_bridge.rig
    if local is None:
        pytest.skip('needs the stand-in (declares tokens a real bridge would act on)')
    config = {
        'mode': 'client',
        'connect': {'endpoints': [bot1_bridge.endpoint]},
        'scouting': {'multicast': {'enabled': False}},
    }
    session = zenoh.open(zenoh.Config.from_json5(json.dumps(config)))
    try:
        zid = str(session.zid())
        qos = p.TokenQos.parse(':1:0:0,10')
        unprefixed = p.Token(zid, p.Kind.MP, 'it_other/x', 'std_msgs/msg/String', qos)
        broken = p.Token(zid, p.Kind.MP, 'bot10/x', 'std_msgs/msg/String', qos)
        tokens = [session.liveliness().declare_token(t.to_key()) for t in (unprefixed, broken)]
        prefix = f'@/{local.zid}/ros2'
        route = f'{prefix}/route/topic/sub/bot1/it_other/x'

        def state() -> tuple[dict[str, Any], list[dict[str, str]]]:
            rejected = admin_get(session, f'{prefix}/standin/rejected')
            return admin_get(session, route), rejected.get(f'{prefix}/standin/rejected', [])

        assert wait_for(lambda: all(state()), TIMEOUT), local.log_tail()
        routes, rejected = state()
        assert routes[route]['ros2_name'] == '/it_other/x'
        assert routes[route]['remote_routes'] == [unprefixed.remote_route]
        assert [entry['token'] for entry in rejected] == [broken.to_key()]
        assert "'0/x'" in rejected[0]['reason']
        for token in tokens:
            token.undeclare()
    finally:
        session.close()


# --- admin space, tokens -------------------------------------------------------------------------


def test_admin_space(interop_bridge: Bridge, raw_session: Any) -> None:
    versions = admin_get(raw_session, '@/*/ros2/version')
    assert versions, 'no bridge answered @/*/ros2/version'
    for key, version in versions.items():
        assert re.fullmatch(r'@/[0-9a-f]+/ros2/version', key)
        assert re.match(r'^v1\.\d+\.\d+', version)
    configs = admin_get(raw_session, '@/*/ros2/config')
    assert [config['namespace'] for config in configs.values()] == [interop_bridge.namespace]
    assert all('nodename' in config for config in configs.values())
    bridges = [str(reply.ok.key_expr) for reply in raw_session.liveliness().get('@/*/@ros2_lv')]
    assert [p.parse_token(token) for token in bridges] == [key.split('/')[1] for key in versions]


def test_bridge_announces_ros_entities(interop: Interop, raw_session: Any) -> None:
    """The bridge declares MP/MS tokens for ROS publishers and subscribers it discovers."""
    ros = interop.ros
    topic = interop.topic('announced')
    key = p.ros_to_key(topic, interop.bridge.namespace)
    ros.publisher(topic, 'std_msgs/msg/String', LATCHED_ROS)
    ros.subscription(topic, 'std_msgs/msg/String', rig.qos_spec(7, reliability='best_effort'))

    def tokens() -> dict[p.Kind, p.Token]:
        found = {}
        for reply in raw_session.liveliness().get('@/*/@ros2_lv/**', timeout=5.0):
            token = p.parse_token(str(reply.ok.key_expr))
            if isinstance(token, p.Token) and token.key == key:
                found[token.kind] = token
        return found

    assert wait_for(lambda: len(tokens()) == 2, TIMEOUT)
    found = tokens()
    assert found[p.Kind.MP].type_name == found[p.Kind.MS].type_name == 'std_msgs/msg/String'
    mp_qos, ms_qos = found[p.Kind.MP].qos, found[p.Kind.MS].qos
    assert mp_qos is not None and ms_qos is not None
    assert (mp_qos.reliability, mp_qos.durability) == (p.RELIABLE, p.TRANSIENT_LOCAL)
    assert ms_qos.reliability == p.BEST_EFFORT
    assert ms_qos.durability in (None, p.VOLATILE)
    ros.cleanup()
    assert wait_for(lambda: not tokens(), TIMEOUT)


MALFORMED = [
    '@/{zid}/@ros2_lv/M',
    '@/{zid}/@ros2_lv/XX/chatter/std_msgs\u00a7msg\u00a7String/:::',
    '@/{zid}/@ros2_lv/MP/chatter/std_msgs\u00a7msg\u00a7String',
    '@/{zid}/@ros2_lv/MP/bad_rel/std_msgs\u00a7msg\u00a7String/:2::',
    '@/{zid}/@ros2_lv/MS/bad_dur/std_msgs\u00a7msg\u00a7String/::4:',
    '@/{zid}/@ros2_lv/MP/bad_hist/std_msgs\u00a7msg\u00a7String/:::5,1',
    '@/{zid}/@ros2_lv/MP/zero_depth/std_msgs\u00a7msg\u00a7String/:1:0:0,0',
    '@/{zid}/@ros2_lv/MP/bad_type/std_msgs\u00a7String/:::',
    '@/{zid}/@ros2_lv/MS/dds_type/std_msgs::msg::dds_::String_/:::',
    '@/{zid}/@ros2_lv/SS/srv_with_msg/std_msgs\u00a7msg\u00a7String',
    '@/{zid}/@ros2_lv/MP/a\u00a7\u00a7b/std_msgs\u00a7msg\u00a7String/:::',
    '@/{zid}/@ros2_lv/MP/too/many/chunks/std_msgs\u00a7msg\u00a7String/:::',
]


def test_standin_rejects_malformed_tokens(
    standin: rig.LocalRig, raw_session: Any, unique_topic: Callable[[str], str]
) -> None:
    zid = str(raw_session.zid())
    good_topic = unique_topic('good')
    good = p.Token(
        zid, p.Kind.MP, good_topic[1:], 'std_msgs/msg/String', p.TokenQos.parse(':1:0:0,10')
    )
    keys = [template.format(zid=zid) for template in MALFORMED]
    tokens = [raw_session.liveliness().declare_token(key) for key in [*keys, good.to_key()]]
    prefix = f'@/{standin.zid}/ros2'

    def rejected() -> set[str]:
        found = admin_get(raw_session, f'{prefix}/standin/rejected')
        return {entry['token'] for entry in found.get(f'{prefix}/standin/rejected', [])}

    assert wait_for(lambda: set(keys) <= rejected(), TIMEOUT), standin.log_tail()
    assert good.to_key() not in rejected()

    def routes() -> dict[str, list[str]]:
        """The routes our tokens made, with their remote routes."""
        return {
            key: route['remote_routes']
            for key, route in admin_get(raw_session, f'{prefix}/route/**').items()
            if any(remote.startswith(f'{zid}:') for remote in route['remote_routes'])
        }

    expected = {f'{prefix}/route/topic/sub/{good.key}': [good.remote_route]}
    assert wait_for(lambda: routes() == expected, TIMEOUT), routes()
    assert standin.standin_alive()
    for token in tokens:
        token.undeclare()
    assert wait_for(lambda: not routes(), TIMEOUT)


ZROS_TOKEN_CASES = [
    ('/', '/', 'chatter', zros.QoS(10)),
    ('/', '/', '/abs/topic', 'sensor_data'),
    ('/', '/robot', '~/private', 'latched'),
    ('/', '/robot', 'relative/deep', 'keep_all'),
    ('/', '/', 'rosout_like', 'rosout'),
    ('/bot1', '/', 'chatter', zros.QoS(1, zros.Reliability.BEST_EFFORT)),
    ('/bot1', '/a/b', '~/x', zros.QoS(7, durability=zros.Durability.TRANSIENT_LOCAL)),
    ('/robots/r2', '/', 'cmd_vel', 'parameter_events'),
]


@pytest.mark.parametrize('case', ZROS_TOKEN_CASES, ids=lambda case: '-'.join(map(str, case)))
def test_zros_tokens_pass_the_bridge_parser(
    case: tuple[str, str, str, Any], interop: Interop, raw_session: Any
) -> None:
    """Every token zros declares parses, maps back to the right ROS name, and carries the QoS."""
    bridge_namespace, node_namespace, topic, qos = case
    node = interop.node('tokens', namespace=node_namespace, bridge_namespace=bridge_namespace)
    name = 'std_msgs/msg/String'
    publisher = node.create_publisher(name, topic, qos)
    node.create_subscription(name, topic, qos=qos)
    expected_qos = zros.qos.as_qos(qos)
    zid = node.transport.zid

    def tokens() -> list[str]:
        replies = raw_session.liveliness().get(f'@/{zid}/@ros2_lv/**', timeout=5.0)
        return [str(reply.ok.key_expr) for reply in replies if reply.ok is not None]

    assert wait_for(lambda: len(tokens()) == 2, TIMEOUT)
    kinds = set()
    for key in tokens():
        token = p.parse_token(key)
        assert isinstance(token, p.Token)
        kinds.add(token.kind)
        assert token.zid == zid
        assert token.key == p.ros_to_key(publisher.topic, bridge_namespace)
        assert p.key_to_ros(token.key, bridge_namespace) == publisher.topic
        assert token.type_name == name
        assert token.qos is not None
        assert token.qos.reliability == int(expected_qos.reliability)
        assert token.qos.durability == int(expected_qos.durability)
        assert token.qos.history == int(expected_qos.history)
        assert token.qos.depth == expected_qos.depth
        assert not token.qos.keyed
        assert token.qos.user_data is None or re.fullmatch(
            r'typehash=RIHS01_[0-9a-f]{64};', token.qos.user_data
        )
    assert kinds == {p.Kind.MP, p.Kind.MS}
    if interop.bridge.rig is not None:
        prefix = f'@/{interop.bridge.rig.zid}/ros2/standin/rejected'
        rejected = admin_get(raw_session, prefix).get(prefix, [])
        assert not [entry for entry in rejected if f'/{zid}/' in entry['token']]


def test_two_publishers_in_one_session_share_the_route(interop: Interop) -> None:
    """The bridge keys remote routes by ``"<zid>:<ke>"`` (§3.3): closing one of two zros
    publishers of one session must not retire the route the other one still uses."""
    name = 'std_msgs/msg/String'
    topic = interop.topic('shared')
    node = interop.node()
    first = node.create_publisher(name, topic, 10)
    second = node.create_publisher(name, topic, 10)
    subscription = interop.ros.subscription(topic, name)
    assert second.wait_for_subscribers(TIMEOUT)
    assert interop.ros.wait_publishers(subscription) >= 1
    first.close()
    message = zros.Message(name, data='still routed')
    second.write(message)
    received = interop.ros.wait_messages(subscription, timeout=TIMEOUT)
    assert_received_by_ros(name, [message], received)
    assert interop.ros.topics().get(topic) == [name]
    second.close()
    interop.ros.destroy(subscription)
    assert topic not in interop.ros.wait_topic(topic, name, present=False)


def test_mixed_publishers_deliver_each_message_once(interop: Interop) -> None:
    """zros and ROS publishers and subscribers on one topic: nobody gets an echo or a copy."""
    name = 'std_msgs/msg/String'
    topic = interop.topic('mixed')
    ros = interop.ros
    ros_subscription = ros.subscription(topic, name)
    zros_publisher = interop.node('talker').create_publisher(name, topic, 10)
    # only the bridge's route can match yet: this waits for it
    assert zros_publisher.wait_for_subscribers(TIMEOUT)
    zros_subscription = interop.node('listener').create_subscription(name, topic, qos=10)
    ros_publisher = ros.publisher(topic, name)
    assert ros.wait_subscribers(ros_publisher, 2) == 2  # its own node's reader and the bridge's
    # each path may open after a put: the router's from the talker to the listener, the
    # bridge's from ROS to the listener and from the talker to ROS. Probe every one until it
    # delivered.
    zros_probe = zros.Message(name, data='probe from zros')
    ros_probe = rclpy_bytes(name, zros.Message(name, data='probe from ros'))
    seen_by_zros: set[str] = set()

    def ros_texts() -> list[str]:
        return [decode(cls(name), data).data for data in ros.wait_messages(ros_subscription, 0)]

    def every_path_delivered() -> bool:
        zros_publisher.write(zros_probe)
        ros.publish(ros_publisher, [ros_probe])
        seen_by_zros.update(m.data for m in zros_subscription.take())
        return seen_by_zros == {'probe from zros', 'probe from ros'} and (
            'probe from zros' in ros_texts()
        )

    assert wait_for(every_path_delivered, TIMEOUT)

    def without_probes(texts: list[str]) -> list[str]:
        return sorted(text for text in texts if not text.startswith('probe'))

    from_zros = [zros.Message(name, data=f'from zros {i}') for i in range(3)]
    from_ros = [zros.Message(name, data=f'from ros {i}') for i in range(3)]
    for message in from_zros:
        zros_publisher.write(message)
    ros.publish(ros_publisher, [rclpy_bytes(name, m) for m in from_ros])
    expected = sorted(m.data for m in from_zros + from_ros)

    received: list[str] = []
    assert wait_for(
        lambda: (
            received.extend(m.data for m in zros_subscription.take())
            or len(without_probes(received)) >= 6
        ),
        TIMEOUT,
    )
    assert without_probes(received) == expected

    assert wait_for(lambda: len(without_probes(ros_texts())) >= 6, TIMEOUT)
    assert without_probes(ros_texts()) == expected
    # nothing more arrives: no message came back through the bridge a second time
    ros.publish(ros_publisher, [rclpy_bytes(name, zros.Message(name, data='end'))])
    assert wait_for(lambda: 'end' in [m.data for m in zros_subscription.take()], TIMEOUT)
    assert wait_for(lambda: 'end' in ros_texts(), TIMEOUT)
    assert zros_subscription.take() == []
    assert without_probes(ros_texts()) == sorted([*expected, 'end'])


def test_zros_log_reaches_a_late_ros_rosout_subscriber(interop: Interop) -> None:
    """zros logs on /rosout (reliable, transient local, keep last 1000): ``ros2 topic echo
    /rosout`` started afterwards still shows the line."""
    name = interop.topic('logger')[1:]
    node = interop.node(name, enable_rosout=True)
    node.get_logger().warning('hello from zros')
    subscription = interop.ros.subscription(
        '/rosout', 'rcl_interfaces/msg/Log', rig.qos_spec(1000, durability='transient_local')
    )
    Log = rclpy_class('rcl_interfaces/msg/Log')

    def lines() -> list[tuple[int, str]]:
        found = interop.ros.wait_messages(subscription, 0)
        logs = [deserialize_message(data, Log) for data in found]
        return [(log.level, log.msg) for log in logs if log.name == name]

    assert wait_for(lines, TIMEOUT)
    assert lines() == [(30, 'hello from zros')]
