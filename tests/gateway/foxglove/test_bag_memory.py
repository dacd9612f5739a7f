"""Serving a longer recording to Foxglove costs the server no more memory than a short one.

The server runs in a process of its own (``bag_memory.play_through``); a real Foxglove client
subscribes to every channel and plays the bag to its end as fast as the server sends, then
again from its middle. The peak
anonymous memory of the server's process may not grow with the bag's length: a bag four times
longer (120 MB more of messages) may cost it at most SLACK more.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.gateway.foxglove.bag_memory import play_through
from tests.gateway.node_process import require
from zros.bag.write.bag_writer import BagTopic, BagWriter
from zros.cdr import default_registry, encode, new_message

pytestmark = pytest.mark.skipif(not Path('/proc/self/status').exists(), reason='Linux /proc')
pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

MB = 1 << 20
#: what the server's peak anonymous memory may grow by when the bag grows four times
SLACK = 32 * MB
#: bytes of each image: 400 of them make 40 MB, 1,600 make 160 MB
IMAGE = 100_000


def _images(path: Path, count: int) -> Path:
    """A bag of ``count`` images of IMAGE bytes on /image, 10 ms apart, each its own."""
    topic = BagTopic.from_registry(default_registry(), '/image', 'sensor_msgs/msg/Image')
    pixels = np.random.default_rng(1).integers(0, 256, IMAGE, np.uint8)
    image = new_message(
        'sensor_msgs/msg/Image', height=1, width=IMAGE, encoding='mono8', step=IMAGE, data=pixels
    )
    with BagWriter(path, compression=None) as writer:
        image_topic = writer.add_topic(topic)
        for index in range(count):
            image.header.stamp.nanosec = index  # no two alike
            writer.write(image_topic, 10_000_000 * (index + 1), encode(image))
    return path


def _middle(count: int) -> tuple[int, int]:
    """The time of the middle message of a bag of ``_images``, and the messages from it on."""
    return 10_000_000 * (count // 2 + 1), count - count // 2


def test_a_longer_bag_costs_the_server_no_more_memory(tmp_path: Path) -> None:
    require()
    small = play_through(_images(tmp_path / 'small', 400), ['/image'], seeks=[_middle(400)])
    large = play_through(_images(tmp_path / 'large', 1600), ['/image'], seeks=[_middle(1600)])
    assert (small.published, large.published) == (600, 2400)
    assert large.received > 0
    growth = large.peak.anonymous - small.peak.anonymous
    assert growth < SLACK, (small.peak.anonymous // MB, large.peak.anonymous // MB)
