"""Topics through ``zros foxglove`` to a real Foxglove client (``@foxglove/ws-protocol``).

Channels follow the graph with ``ros2msg`` schemas and ``cdr`` encoding; a client gets the
exact CDR bytes a zros publisher sent; a topic has a Zenoh subscription only while a client
watches it (measured on the gateway's link to the router); latched topics reach late clients;
stamps follow sim time; topics are selected by regex. Both wires.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import zros
from tests.gateway.foxglove.client import FoxgloveClient, image
from tests.support.delay_proxy import DelayProxy
from zros.cdr import default_registry
from zros.cdr.render import render_bundle
from zros.qos import QoS
from zros.testing import wait_for
from zros.transport import Transport, TransportConfig

pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

Make = Callable[..., Any]
TIMEOUT = 20.0


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    return str(request.param)


def test_a_client_gets_the_cdr_bytes_a_zros_publisher_sent(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    talker = zros_node('talker')
    pub = talker.create_publisher('sensor_msgs/msg/Imu', '/imu')
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    info = client.server_info()
    assert {'clientPublish', 'services', 'parameters', 'connectionGraph'} <= set(
        info['capabilities']
    )
    assert 'time' not in info['capabilities']
    channel = client.channel('/imu')
    assert channel['encoding'] == 'cdr'
    assert channel['schemaEncoding'] == 'ros2msg'
    assert channel['schemaName'] == 'sensor_msgs/msg/Imu'
    assert channel['schema'] == render_bundle(default_registry(), 'sensor_msgs/msg/Imu')
    subscription = client.subscribe('/imu')
    assert wait_for(lambda: server.watched() == {'/imu': 1}, TIMEOUT)
    assert pub.wait_for_subscribers(TIMEOUT)
    sent = []
    for i in range(5):
        message = zros.Message(
            'sensor_msgs/msg/Imu',
            header={'frame_id': f'imu{i}', 'stamp': {'sec': i, 'nanosec': 7}},
            linear_acceleration={'x': i + 0.5, 'z': -9.81},
            orientation_covariance=np.arange(9, dtype=np.float64) * i,
        )
        before = time.time_ns()
        pub.write(message)
        sent.append(message.serialize())
    received = client.wait_messages(subscription, 5, TIMEOUT)
    assert received == sent  # byte for byte, in order
    stamp = int(client.of('message')[0]['timestamp'])
    assert before - 10**10 < stamp < time.time_ns()  # receive time (wall clock, ns)


def test_a_burst_reaches_a_client_whole_from_its_first_message(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    """A reliable keep_all publisher's burst, sent the moment the gateway taps the topic,
    reaches a client whose outbox holds it: every message, counted from the first."""
    count = 5000
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/String', '/burst', qos='keep_all')
    server = gateway(message_backlog=2 * count)
    client: FoxgloveClient = foxglove_client(server.url)
    subscription = client.subscribe('/burst', quiet=True)
    assert pub.wait_for_subscribers(TIMEOUT)
    message = zros.Message('std_msgs/msg/String', data='x' * 30)
    for _ in range(count):
        pub.write(message)

    def counted() -> int:
        return int(client.stats()[str(subscription)]['count'])

    assert wait_for(lambda: counted() >= count, TIMEOUT * 3)
    assert server.forwarded('/burst')[0] == count
    assert counted() == count  # and not one more


def test_channels_come_and_go_with_the_graph(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    server = gateway()
    client: FoxgloveClient = foxglove_client(server.url)
    client.server_info()
    talker = zros_node('talker')
    pub = talker.create_publisher('std_msgs/msg/String', '/arrives')
    channel = client.channel('/arrives')
    assert server.channels['/arrives'] == 'std_msgs/msg/String'
    client.subscribe('/arrives')  # the gateway's own subscription does not keep the topic
    assert wait_for(lambda: server.watched() == {'/arrives': 1}, TIMEOUT)
    start = client.mark()
    pub.close()
    client.wait(
        lambda e: e['ev'] == 'unadvertise' and channel['id'] in e['channelIds'], start=start
    )
    assert '/arrives' not in server.channels
    assert wait_for(lambda: server.watched() == {}, TIMEOUT)


def test_unwatched_topics_carry_no_zenoh_traffic(
    zros_router: Any, gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    """Measured on the link between the router and the gateway: 2 MB put on a topic nobody
    watches never reach it; the same 2 MB once a client watches do."""
    host, port = zros_router.endpoint.split('/')[1].rsplit(':', 1)
    with DelayProxy((host, int(port)), delay=0.0) as meter:
        transport = Transport(TransportConfig.create(connect=meter.endpoint, shared_memory=False))
        try:
            node = zros_node(
                'zros_foxglove',
                transport=transport,
                enable_rosout=False,
                start_parameter_services=False,
            )
            server = gateway(node=node)
            talker = zros_node('talker')
            # block, not drop (the default for keep-last): a burst of 100 kB frames through the
            # meter's proxy overflowed Zenoh's queue under load and lost frames before the gateway
            big = talker.create_publisher(
                'sensor_msgs/msg/Image', '/camera', QoS(10, congestion='block')
            )
            fence = talker.create_publisher('std_msgs/msg/UInt32', '/fence')
            client: FoxgloveClient = foxglove_client(server.url)
            client.channel('/camera')
            fences = client.subscribe('/fence')
            assert fence.wait_for_subscribers(TIMEOUT)

            def put_frames(round_: int) -> int:
                """20 frames of 100 kB, then a fence; the downlink bytes they cost the gateway."""
                before = meter.relayed['down']
                for i in range(20):
                    big.write(image(200, 167, i))
                fence.write(zros.Message('std_msgs/msg/UInt32', data=round_))
                client.wait(lambda e: client.count(fences) >= round_ + 1, TIMEOUT)
                return meter.relayed['down'] - before

            assert not big.has_subscribers  # the publisher itself sends nothing
            unwatched = put_frames(0)
            assert server.watched() == {'/fence': 1}
            assert server.forwarded('/camera') == (0, 0)
            frames = client.subscribe('/camera')
            assert big.wait_for_subscribers(TIMEOUT)
            watched = put_frames(1)
            assert len(client.wait_messages(frames, 20, TIMEOUT)) == 20
            assert server.forwarded('/camera')[0] == 20
            client.send('unsubscribe', subscriptionId=frames)
            assert wait_for(lambda: '/camera' not in server.watched(), TIMEOUT)
            assert wait_for(lambda: not big.has_subscribers, TIMEOUT)
            released = put_frames(2)
        finally:
            client.close()
            server.close()
            transport.close()
    size = 20 * 200 * 167 * 3
    assert watched > size  # every frame crossed the link
    assert unwatched < size / 20 and released < size / 20  # not even one frame did


def test_a_late_client_gets_latched_messages(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    talker = zros_node('talker')
    static = talker.create_publisher('tf2_msgs/msg/TFMessage', '/tf_static', 'latched')
    transform = {
        'header': {'frame_id': 'base_link'},
        'child_frame_id': 'laser',
        'transform': {'translation': {'x': 0.2}, 'rotation': {'w': 1.0}},
    }
    message = zros.Message('tf2_msgs/msg/TFMessage', transforms=[transform])
    static.write(message)  # before any gateway or client exists
    server = gateway()
    first: FoxgloveClient = foxglove_client(server.url)
    assert first.wait_messages(first.subscribe('/tf_static'), 1, TIMEOUT) == [message.serialize()]
    second: FoxgloveClient = foxglove_client(server.url)  # the topic is tapped already
    assert second.wait_messages(second.subscribe('/tf_static'), 1, TIMEOUT) == [message.serialize()]
    assert server.watched() == {'/tf_static': 2}


def test_stamps_follow_sim_time_when_clock_is_published(
    gateway: Make, foxglove_client: Make, zros_node: Make, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG, 'zros.gateway')
    sim = zros_node('sim')
    clock = sim.create_publisher('rosgraph_msgs/msg/Clock', '/clock', 'sensor_data')
    pub = sim.create_publisher('std_msgs/msg/String', '/chatter')
    sim.graph.wait_until(lambda: '/clock' in dict(sim.get_topic_names_and_types()), TIMEOUT)
    server = gateway(sim_time=None)  # decides by itself: /clock has a publisher
    assert server.sim_time
    client: FoxgloveClient = foxglove_client(server.url)
    assert 'time' in client.server_info()['capabilities']
    subscription = client.subscribe('/chatter')
    assert pub.wait_for_subscribers(TIMEOUT)
    tick = zros.Message('rosgraph_msgs/msg/Clock', clock={'sec': 42, 'nanosec': 5})

    def refused() -> bool:  # a /clock message that does not decode is dropped
        clock.write_raw(b'\x00\x01\x00\x00\x01')
        return 'a /clock message does not decode' in caplog.text

    assert wait_for(refused, TIMEOUT)
    assert server.now() == 0

    def ticked() -> bool:
        clock.write(tick)
        return server.now() == 42 * 10**9 + 5

    assert wait_for(ticked, TIMEOUT)
    client.wait(lambda e: e['ev'] == 'time' and e['timestamp'] == str(42 * 10**9 + 5))
    pub.write(zros.Message('std_msgs/msg/String', data='in sim time'))
    client.wait_messages(subscription, 1, TIMEOUT)
    assert client.of('message')[0]['timestamp'] == str(42 * 10**9 + 5)


def test_topics_are_selected_by_regex(
    gateway: Make, foxglove_client: Make, zros_node: Make
) -> None:
    talker = zros_node('talker')
    for topic in ('/keep/a', '/keep/secret', '/other', '/keep/_hidden'):
        talker.create_publisher('std_msgs/msg/String', topic)
    server = gateway(topics=['/keep/.*'], exclude=['.*secret'])
    client: FoxgloveClient = foxglove_client(server.url)
    client.channel('/keep/a')
    assert wait_for(lambda: set(server.channels) == {'/keep/a'}, TIMEOUT)
    assert set(client.channels()) == {'/keep/a'}
    hidden = gateway(topics=['/keep/.*'], include_hidden=True)
    assert wait_for(
        lambda: set(hidden.channels) == {'/keep/a', '/keep/secret', '/keep/_hidden'}, TIMEOUT
    )
