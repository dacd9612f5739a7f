"""A remote viewer never slows the robot: congestion control across a 10 Mbit/s, 50 ms link
(tests/runtime/wan_rig.py), on both wires."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

import zros
from tests.runtime.wan_rig import Wan, wan
from zros.node import Node
from zros.qos import Congestion, History, QoS
from zros.testing import wait_for

IMAGE = 900_000  #: bytes of image data (640x480 rgb8 is 921,600)


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def rig(request: pytest.FixtureRequest) -> Iterator[Wan]:
    with wan(request.param) as made:
        yield made


def _image(number: int) -> zros.Message:
    image = zros.Message(
        'sensor_msgs/msg/Image', height=1, width=IMAGE, encoding='mono8', step=IMAGE,
        data=bytes(IMAGE),
    )  # fmt: skip
    image.header.frame_id = str(number)
    return image


def _camera(rig: Wan, qos: QoS) -> tuple[Node, zros.Publisher, zros.Subscriber]:
    robot = rig.node('robot', remote=False)
    laptop = rig.node('laptop', remote=True)
    seen = laptop.create_subscription('sensor_msgs/msg/Image', 'camera', qos=qos)
    camera = robot.create_publisher('sensor_msgs/msg/Image', 'camera', qos=qos)
    assert camera.wait_for_subscribers(10)
    return robot, camera, seen


def _publish(camera: zros.Publisher, count: int, period: float) -> list[float]:
    """Write ``count`` images every ``period`` seconds; how long each write() took."""
    took = []
    start = time.monotonic()
    for number in range(count):
        image = _image(number)
        before = time.perf_counter()
        camera.write(image)
        took.append(time.perf_counter() - before)
        time.sleep(max(0.0, start + (number + 1) * period - time.monotonic()))
    return took


def test_a_keep_last_writer_never_waits_for_a_slow_link_and_the_newest_arrives(rig: Wan) -> None:
    _, camera, seen = _camera(rig, QoS(1))
    assert camera.qos.congestion_control is Congestion.BLOCK_FIRST
    took = _publish(camera, 100, 0.1)  # 9 MB/s into a link of 1.25 MB/s
    assert max(took) < 0.05, f'the slowest write() took {max(took) * 1e3:.0f} ms'
    arrived: list[int] = []

    def newest() -> bool:
        # the link takes 0.72 s an image: the one on its way when the last was written is at
        # most 8 older, and Zenoh drops what comes while one is on its way (block_first)
        arrived.extend(int(m.header.frame_id) for m in seen.take())
        return bool(arrived) and arrived[-1] >= 100 - 10

    assert wait_for(newest, 10), f'the last images that arrived: {arrived[-3:]}'
    assert not wait_for(seen.has_new_message, 1.5)  # nothing stale replayed after it
    assert arrived == sorted(set(arrived))
    assert 5 < seen.received < 30  # about what the link carries in 10 s, as it was written


def test_a_keep_all_writer_blocks_until_every_message_is_sent(rig: Wan) -> None:
    keep_all = QoS(10, history=History.KEEP_ALL)
    _, camera, seen = _camera(rig, keep_all)
    assert camera.qos.congestion_control is Congestion.BLOCK
    took = _publish(camera, 6, 0.1)
    assert max(took) > 0.2  # the link carries one image in 0.72 s: the writer waits for it
    assert wait_for(lambda: seen.received == 6, 10)
    assert [int(m.header.frame_id) for m in seen.take()] == list(range(6))
