"""What ``topic echo --raw`` and ``--include-message-info`` read: each sample of a topic with
its CDR bytes and what ros2 calls its message info."""

from __future__ import annotations

import contextlib
import queue
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

        self._samples: queue.Queue[tuple[Sample, int, int]] = queue.Queue(max(qos.depth, 1))
        self._lock = threading.Lock()
        self._received = 0
        self._tap = RawTap(node, topic, type_name, qos=qos, key=None, callback=self._arrived)

    def _arrived(self, sample: Sample) -> None:
        now = time.time_ns()
        with self._lock:  # one delivery thread, but Zenoh's for transient local too
            self._received += 1
            entry = (sample, now, self._received)
            while True:
                try:
                    self._samples.put_nowait(entry)
                    return
                except queue.Full:
                    with contextlib.suppress(queue.Empty):  # keep last: the oldest goes
                        self._samples.get_nowait()

    def next(self, timeout: float) -> tuple[bytes, dict[str, int]] | None:
        """The CDR bytes and message info of the next sample; None after ``timeout`` s."""
        from zros.pubsub.taps import publish_time
        from zros.wire import read_attachment

        try:
            sample, received, number = self._samples.get(timeout=timeout)
        except queue.Empty:
            return None
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
