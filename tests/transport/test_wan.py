"""A remote viewer never slows the robot: congestion control across a 10 Mbit/s, 50 ms link
(tests/support/wan_rig.py), on both wires."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator

import pytest
import zenoh

import zros
from tests.support.wan_rig import Wan, numbered_image, wan
from zros.node import Node
from zros.qos import Congestion, History, Priority, QoS
from zros.testing import wait_for
from zros.transport import Transport, TransportConfig, TransportError, start_router
from zros.transport.router import downsampling

IMAGE = 900_000  #: bytes of image data (640x480 rgb8 is 921,600)


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def rig(request: pytest.FixtureRequest) -> Iterator[Wan]:
    with wan(request.param) as made:
        yield made


def _camera(rig: Wan, qos: QoS) -> tuple[Node, zros.Publisher, zros.Subscriber]:
    robot = rig.node('robot', remote=False)
    laptop = rig.node('laptop', remote=True)
    seen = laptop.create_subscription('sensor_msgs/msg/Image', 'camera', qos=qos)
    camera = robot.create_publisher('sensor_msgs/msg/Image', 'camera', qos=qos)
    assert camera.wait_for_subscribers(10)
    return robot, camera, seen


def _quiet(rig: Wan) -> Callable[[], bool]:
    """A condition: nothing crossed the link towards the laptop for a second."""
    last = [-1, time.monotonic()]

    def quiet() -> bool:
        relayed = rig.proxy.relayed['down']
        if relayed != last[0]:
            last[:] = [relayed, time.monotonic()]
        return time.monotonic() - last[1] > 1.0

    return quiet


def _publish(camera: zros.Publisher, count: int, period: float) -> list[float]:
    """Write ``count`` images every ``period`` seconds; how long each write() took."""
    took = []
    start = time.monotonic()
    for number in range(count):
        image = numbered_image(number, IMAGE)
        before = time.perf_counter()
        camera.write(image)
        took.append(time.perf_counter() - before)
        time.sleep(max(0.0, start + (number + 1) * period - time.monotonic()))
    return took


def test_a_keep_last_writer_never_waits_for_a_slow_link_and_the_newest_arrives(rig: Wan) -> None:
    _, camera, seen = _camera(rig, QoS(1))
    # the publisher drops on a full link (as rmw_zenoh); the robot's zros router sends large
    # messages on with block_first, so that the newest still crosses whole
    assert camera.qos.congestion_control is Congestion.DROP
    took = _publish(camera, 100, 0.1)  # 9 MB/s into a link of 1.25 MB/s
    assert max(took) < 0.05, f'the slowest write() took {max(took) * 1e3:.0f} ms'
    arrived: list[int] = []

    def newest() -> bool:
        arrived.extend(int(m.header.frame_id) for m in seen.take())
        return bool(arrived) and arrived[-1] == 99

    # the link takes 0.72 s an image, and Zenoh drops what comes while one is on its way
    # (block_first): the one on its way when the last was written may be 8 older; once the
    # stream has paused, the subscriber asks for the newest, which comes on its own
    assert wait_for(newest, 20), f'the last images that arrived: {arrived[-3:]}'
    assert seen.recovered <= 1
    assert wait_for(_quiet(rig), 10)  # and nothing after it
    arrived.extend(int(m.header.frame_id) for m in seen.take())
    assert arrived[-1] == 99 and arrived == sorted(set(arrived))  # in order, nothing replayed
    assert 5 < seen.received < 30  # about what the link carries in 10 s, as it was written


def test_a_robot_behind_the_slow_link_asks_for_block_first_itself() -> None:
    # no router between the robot and the slow link: its own session's queue is the bottleneck
    with wan('bridge', large_payloads=False) as rig:
        robot = rig.node('robot', remote=True)
        laptop = rig.node('laptop', remote=False)
        seen = laptop.create_subscription('sensor_msgs/msg/Image', 'camera', qos=1)
        newest = QoS(1, congestion='block_first')
        camera = robot.create_publisher('sensor_msgs/msg/Image', 'camera', qos=newest)
        assert camera.wait_for_subscribers(10)
        took = _publish(camera, 30, 0.1)
        assert max(took) < 0.05, f'the slowest write() took {max(took) * 1e3:.0f} ms'
        assert wait_for(lambda: seen.received >= 2, 10)  # under drop, none would arrive whole
        arrived: list[int] = []

        def newest() -> bool:  # asked for, and sent block_first as the stream was
            arrived.extend(int(m.header.frame_id) for m in seen.take())
            return bool(arrived) and arrived[-1] == 29

        assert wait_for(newest, 20), arrived[-3:]


def test_a_keep_all_writer_blocks_until_every_message_is_sent(rig: Wan) -> None:
    keep_all = QoS(10, history=History.KEEP_ALL)
    _, camera, seen = _camera(rig, keep_all)
    assert camera.qos.congestion_control is Congestion.BLOCK
    took = _publish(camera, 6, 0.1)
    assert max(took) > 0.2  # the link carries one image in 0.72 s: the writer waits for it
    assert wait_for(lambda: seen.received == 6, 10)
    assert [int(m.header.frame_id) for m in seen.take()] == list(range(6))


def test_small_urgent_messages_overtake_images_that_saturate_the_link(rig: Wan) -> None:
    robot = rig.node('robot', remote=False)
    laptop = rig.node('laptop', remote=True)
    ages: list[float] = []

    def on_command(message: zros.Message) -> None:
        stamp = message.header.stamp
        ages.append(time.time() - stamp.sec - stamp.nanosec * 1e-9)

    laptop.create_subscription('geometry_msgs/msg/TwistStamped', 'cmd_vel', on_command, qos=100)
    seen = laptop.create_subscription('sensor_msgs/msg/Image', 'camera', qos=1)
    camera = robot.create_publisher('sensor_msgs/msg/Image', 'camera', qos=1)
    command = robot.create_publisher('geometry_msgs/msg/TwistStamped', 'cmd_vel')
    assert (camera.priority, command.priority) == (Priority.DATA_LOW, Priority.INTERACTIVE_HIGH)
    assert command.express and not camera.express
    assert camera.wait_for_subscribers(10) and command.wait_for_subscribers(10)
    stop = threading.Event()
    spinner = threading.Thread(
        target=lambda: [laptop.spin_once(0.05) for _ in iter(stop.is_set, True)]
    )
    spinner.start()
    try:
        start = time.monotonic()
        for number in range(30):  # 9 MB/s of images into 1.25 MB/s, and 10 commands a second
            camera.write(numbered_image(number, IMAGE))
            twist = zros.Message('geometry_msgs/msg/TwistStamped')
            now = time.time_ns()
            twist.header.stamp.sec, twist.header.stamp.nanosec = divmod(now, 10**9)
            command.write(twist)
            time.sleep(max(0.0, start + (number + 1) * 0.1 - time.monotonic()))
        assert wait_for(lambda: len(ages) == 30, 5), f'{len(ages)} of 30 commands arrived'
    finally:
        stop.set()
        spinner.join(5)
    ages.sort()
    assert ages[-1] < 0.5, f'commands arrived up to {ages[-1]:.2f} s old'
    assert seen.received > 1  # the images saturated the link all along


# --- what a zros router does for slow links ---------------------------------------------------


def test_a_router_sends_large_dropped_messages_block_first_and_default_ones_last() -> None:
    first, drop, block = (
        'CongestionControl.BLOCK_FIRST',
        'CongestionControl.DROP',
        'CongestionControl.BLOCK',
    )
    for large_payloads, large, urgent in (
        (True, f'{first} Priority.DATA_LOW', f'{first} Priority.INTERACTIVE_HIGH'),
        (False, f'{drop} Priority.DATA', f'{drop} Priority.INTERACTIVE_HIGH'),
    ):
        with start_router(large_payloads=large_payloads) as router:
            sessions = [
                Transport(TransportConfig.create(connect=router.endpoint, shared_memory=False))
                for _ in range(2)
            ]
            try:
                samples: list[zenoh.Sample] = []
                sessions[1].session.declare_subscriber('k/*', samples.append)
                sender = sessions[0].session
                publisher = sender.declare_publisher('k/*')
                assert wait_for(lambda p=publisher: p.matching_status.matching)
                sender.put('k/small', bytes(100))
                sender.put('k/large', bytes(100_000))
                sender.put('k/urgent', bytes(100_000), priority=zenoh.Priority.INTERACTIVE_HIGH)
                sender.put(
                    'k/every', bytes(100_000), congestion_control=zenoh.CongestionControl.BLOCK
                )
                assert wait_for(lambda s=samples: len(s) == 4)
            finally:
                for transport in sessions:
                    transport.close()
        seen = {str(s.key_expr): f'{s.congestion_control} {s.priority}' for s in samples}
        assert seen == {
            'k/small': f'{drop} Priority.DATA',
            'k/large': large,
            'k/urgent': urgent,  # the sender's priority stays
            'k/every': f'{block} Priority.DATA',  # and so does block (keep-all)
        }


def test_sessions_wait_25_ms_for_room_for_a_large_message_unless_told() -> None:
    key = 'transport/link/tx/queue/congestion_control/drop/max_wait_before_drop_fragments'
    assert TransportConfig.create(connect='tcp/127.0.0.1:7447').to_zenoh().get_json(key) == '25000'
    told = TransportConfig.create(connect='tcp/127.0.0.1:7447', zenoh={key: 50_000})
    assert told.to_zenoh().get_json(key) == '50000'


@pytest.mark.parametrize('wire', ['bridge', 'rmw_zenoh'])
def test_a_router_downsamples_a_topic_out_of_each_link(wire: str) -> None:
    with start_router(downsample={'/fast': 5.0}) as router:
        nodes = [
            Node(name, wire=wire, transport=Transport(
                TransportConfig.create(connect=router.endpoint, shared_memory=False)
            ))
            for name in ('talker', 'listener')
        ]  # fmt: skip
        try:
            fast = nodes[1].create_subscription('std_msgs/msg/Int32', '/fast', qos=100)
            slow = nodes[1].create_subscription('std_msgs/msg/Int32', '/slow', qos=100)
            publishers = [
                nodes[0].create_publisher('std_msgs/msg/Int32', t) for t in ('/fast', '/slow')
            ]
            assert all(p.wait_for_subscribers() for p in publishers)
            start = time.monotonic()
            for number in range(50):  # 50 Hz for a second
                for publisher in publishers:
                    publisher.write(zros.Message('std_msgs/msg/Int32', data=number))
                time.sleep(max(0.0, start + (number + 1) * 0.02 - time.monotonic()))
            assert wait_for(lambda: slow.received == 50)
            assert 3 <= fast.received <= 8, fast.received  # 5 a second, and the first at once
        finally:
            for node in nodes:
                node.destroy()
                node.transport.close()


def test_downsampling_refuses_what_is_not_a_topic_and_a_rate() -> None:
    for rates in ({'/': 2.0}, {'/a//b': 2.0}, {'/camera': 0.0}):
        with pytest.raises(TransportError, match='give /topic=HZ, HZ > 0'):
            downsampling(rates)
