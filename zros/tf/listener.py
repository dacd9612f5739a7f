"""``TransformListener``: fills a buffer from ``/tf`` and ``/tf_static`` as they arrive.

Two raw taps (``zros.pubsub.taps``) hand each sample over on the delivery thread, which
decodes it and adds its transforms to the buffer at once: no spinning is needed, as with
tf2_ros's listener and its own thread. Each sender is named once (the graph's name for it)
and that name is the authority bad transforms are reported under.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from zenoh import Sample

from zros.cdr import CdrError
from zros.cdr.classes import compiled_decoder
from zros.cdr.message import decode
from zros.pubsub.senders import describe_sender
from zros.pubsub.taps import RawTap
from zros.qos import Durability, QoS
from zros.runtime.defaults import NodeLike, default_node
from zros.runtime.drops import sender_key
from zros.runtime.entity import message_class
from zros.tf.buffer import Buffer

_log = logging.getLogger('zros.tf')

TF_TYPE = 'tf2_msgs/msg/TFMessage'
#: tf2_ros's listener QoS: reliable, volatile, keep last 100
LISTENER_QOS = QoS(100)
#: tf2_ros's static listener QoS: reliable, transient local (latched), keep last
STATIC_LISTENER_QOS = QoS(100, durability=Durability.TRANSIENT_LOCAL)
#: senders named per listener; past this they are named by their key alone
MAX_SENDERS = 256
#: seconds before a sender's name is looked up in the graph again
RENAME_AFTER = 1.0


class TransformListener:
    """Subscribes ``/tf`` and ``/tf_static`` (remappings honoured) and adds what arrives to
    ``buffer``. Static transforms published before the listener started arrive too (the
    static topic is transient local)."""

    def __init__(
        self,
        buffer: Buffer,
        node: NodeLike | None = None,
        *,
        qos: QoS = LISTENER_QOS,
        static_qos: QoS = STATIC_LISTENER_QOS,
    ) -> None:
        self.buffer = buffer
        self.node = node if node is not None else default_node()
        context = self.node.context
        self._context = context
        self._class = message_class(context.registry, TF_TYPE)
        self._decoder = compiled_decoder(self._class)
        #: (sender, topic) -> its name, and when to ask the graph again
        self._names: dict[tuple[str, str], tuple[str, float]] = {}
        self.undecodable = 0  #: samples that were not a TFMessage
        self.topics = (context.resolve_name('/tf'), context.resolve_name('/tf_static'))
        self._taps: list[RawTap] = []
        try:
            for topic, topic_qos, static in (
                (self.topics[0], qos, False),
                (self.topics[1], static_qos, True),
            ):
                self._taps.append(
                    RawTap(
                        self.node, topic, TF_TYPE, qos=topic_qos, key=None,
                        batches=self._receiver(topic, static),
                    )
                )  # fmt: skip
        except BaseException:
            self.unregister()
            raise

    def _authority(self, sample: Sample, topic: str) -> str:
        key = (sender_key(sample), topic)
        known = self._names.get(key)
        now = time.monotonic()
        if known is not None and now < known[1]:
            return known[0]
        # asked again now and then: a sample can overtake its publisher's announcement
        name = describe_sender(sample, key[0], self._context, topic)
        if len(self._names) < MAX_SENDERS or key in self._names:
            self._names[key] = (name, now + RENAME_AFTER)
        return name

    def _receiver(self, topic: str, static: bool) -> Callable[[list[Sample]], None]:
        def receive(samples: list[Sample]) -> None:
            self._on_samples(samples, topic, static)

        return receive

    def _on_samples(self, samples: list[Sample], topic: str, static: bool) -> None:
        buffer = self.buffer
        add = buffer.set_transform_static if static else buffer.set_transform
        for sample in samples:
            data = sample.payload.to_bytes()
            try:
                message = self._decoder(data, False)
            except Exception:
                try:
                    message = decode(self._class, data)
                except CdrError as exc:
                    self.undecodable += 1
                    authority = self._authority(sample, topic)
                    told = (
                        f'ignoring a message on {topic} from {authority}: it does not decode '
                        f'as {TF_TYPE}: {exc}'
                    )
                    buffer.rejections.report('TF_UNDECODABLE', authority, '', told)
                    continue
            authority = self._authority(sample, topic)
            for transform in message.transforms:
                add(transform, authority)

    def unregister(self) -> None:
        """Stop listening (the buffer keeps what it holds)."""
        for tap in self._taps:
            tap.close()
        self._taps.clear()

    close = unregister

    def __repr__(self) -> str:
        return f'<zros.tf.TransformListener on {", ".join(self.topics)}>'
