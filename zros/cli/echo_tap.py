"""What ``topic echo --raw`` and ``--include-message-info`` read: each sample of a topic with
its CDR bytes and what ros2 calls its message info."""

from __future__ import annotations

import collections
import threading
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zenoh import Sample

    from zros.node import Node
    from zros.qos import QoS

#: ros2's message info fields, in the order its ``--csv`` prints them
INFO_FIELDS = (
    'source_timestamp',
    'received_timestamp',
    'publication_sequence_number',
    'reception_sequence_number',
)


class EchoTap:
    """The samples of ``topic`` as they arrive, in a queue of ``qos.depth`` (the oldest
    dropped when full), each with its message info (:data:`INFO_FIELDS`): when it was
    published (its rmw_zenoh attachment's time, else its Zenoh timestamp, else when it
    arrived), when it arrived (nanoseconds since the epoch), the publisher's sequence number
    (rmw_zenoh's attachment; 0, ROS's "unsupported", without one), and its number here."""

    def __init__(self, node: Node, topic: str, type_name: str, qos: QoS) -> None:
        from zros.pubsub.taps import RawTap

        # keep last: a full deque drops its oldest
        self._samples: collections.deque[tuple[Sample, int, int]] = collections.deque(
            maxlen=max(qos.depth, 1)
        )
        self._arrival = threading.Condition()
        self._received = 0
        self._tap = RawTap(node, topic, type_name, qos=qos, key=None, callback=self._arrived)

    def _arrived(self, sample: Sample) -> None:
        now = time.time_ns()
        with self._arrival:  # one delivery thread, but Zenoh's for transient local too
            self._received += 1
            self._samples.append((sample, now, self._received))
            self._arrival.notify()

    def next(self, timeout: float) -> tuple[bytes, dict[str, int]] | None:
        """The CDR bytes and message info of the next sample; None after ``timeout`` s."""
        from zros.pubsub.taps import publish_time
        from zros.wire import read_attachment

        with self._arrival:
            if not self._arrival.wait_for(lambda: self._samples, timeout):
                return None
            sample, received, number = self._samples.popleft()
        attachment = read_attachment(sample) if sample.attachment is not None else None
        values = (
            publish_time(sample, received),
            received,
            attachment.sequence_number if attachment is not None else 0,
            number,
        )
        return sample.payload.to_bytes(), dict(zip(INFO_FIELDS, values, strict=True))

    def close(self) -> None:
        """Withdraw the tap."""
        self._tap.close()
