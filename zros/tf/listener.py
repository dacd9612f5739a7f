"""``TransformListener``: fills a buffer from ``/tf`` and ``/tf_static`` as they arrive.

Two raw taps (``zros.pubsub.taps``) hand each sample over on the delivery thread, which
decodes it and adds its transforms to the buffer at once: no spinning is needed, as with
tf2_ros's listener and its own thread. Each sender is an authority the graph names when it
is shown (in ``zros tf frames``, in the report of a bad transform).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

from zenoh import Sample

from zros.cdr import CdrError, Message
from zros.cdr.classes import compiled_decoder
from zros.cdr.message import decode
from zros.pubsub.senders import describe_sender
from zros.pubsub.taps import RawTap
from zros.qos import Durability, QoS, QoSLike, as_qos
from zros.runtime.context import NodeContext
from zros.runtime.defaults import NodeLike, default_node
from zros.runtime.drops import sender_key
from zros.runtime.entity import message_class
from zros.tf.buffer import Buffer
from zros.tf.checks import Authority

_log = logging.getLogger('zros.tf')

TF_TYPE = 'tf2_msgs/msg/TFMessage'
#: tf2_ros's listener QoS: reliable, volatile, keep last 100
LISTENER_QOS = QoS(100)
#: tf2_ros's static listener QoS: reliable, transient local (latched), keep last
STATIC_LISTENER_QOS = QoS(100, durability=Durability.TRANSIENT_LOCAL)
#: senders named per listener; past this they are named by their key alone
MAX_SENDERS = 256
#: seconds a sender's name is kept before the graph is asked again
RENAME_AFTER = 1.0
#: how far the node's clock must go back for the buffer to be cleared (tf2_ros's: 1 s)
JUMP_BACK = 1_000_000_000


class _Sender:
    """A sender of transforms, named by the graph when shown (``str``). The name is asked
    again once it is older than :data:`RENAME_AFTER`: a sample can overtake its publisher's
    announcement, and a latched transform arrives only once."""

    __slots__ = ('_context', '_key', '_name', '_sample', '_topic', '_until')

    def __init__(self, context: NodeContext, key: str, topic: str, sample: Sample) -> None:
        self._context = context
        self._key = key
        self._topic = topic
        self._sample = sample  #: the first sample (its timestamp names the session)
        self._name = key
        self._until = 0.0

    def __str__(self) -> str:
        now = time.monotonic()
        if now >= self._until:
            self._name = describe_sender(self._sample, self._key, self._context, self._topic)
            self._until = now + RENAME_AFTER
        return self._name


class TransformListener:
    """Subscribes ``/tf`` and ``/tf_static`` (remappings honoured) and adds what arrives to
    ``buffer``. Static transforms published before the listener started arrive too (the
    static topic is transient local). ``static_only`` listens to ``tf_static_topic`` alone.

    ``on_message(message, authority, static)`` (zros's own; ``zros tf monitor`` uses it) is
    called with each ``TFMessage`` once its transforms are in the buffer, on the delivery
    thread; what it raises is logged.
    """

    def __init__(
        self,
        buffer: Buffer,
        node: NodeLike | None = None,
        *,
        spin_thread: bool = False,
        qos: QoSLike | None = None,
        static_qos: QoSLike | None = None,
        tf_topic: str = '/tf',
        tf_static_topic: str = '/tf_static',
        static_only: bool = False,
        on_message: Callable[[Message, Authority, bool], object] | None = None,
    ) -> None:
        # rclpy's names: ``spin_thread`` is accepted and has nothing to do (the listener fills
        # the buffer on the delivery threads, never waiting for a spin); ``qos`` and
        # ``static_qos`` take a QoS, a depth or a preset name, tf2_ros's profiles by default
        del spin_thread
        qos = LISTENER_QOS if qos is None else as_qos(qos)
        static_qos = STATIC_LISTENER_QOS if static_qos is None else as_qos(static_qos)
        self.buffer = buffer
        self._on_message = on_message
        self.node = node if node is not None else default_node()
        context = self.node.context
        self._context = context
        self._class = message_class(context.registry, TF_TYPE)
        self._decoder = compiled_decoder(self._class)
        self._senders: dict[tuple[str, str], _Sender] = {}  #: by (sender key, topic)
        self.undecodable = 0  #: samples that were not a TFMessage
        self._clock = context.clock
        self._last_now = 0  #: the clock when transforms last came (ns)
        self._jump_lock = threading.Lock()
        static_topic = (context.resolve_name(tf_static_topic), static_qos, True)
        if static_only:
            listened = [static_topic]
        else:
            listened = [(context.resolve_name(tf_topic), qos, False), static_topic]
        #: the topics listened to, resolved
        self.topics = tuple(topic for topic, _, _ in listened)
        self._taps: list[RawTap] = []
        try:
            for topic, topic_qos, static in listened:
                self._taps.append(
                    RawTap(
                        self.node, topic, TF_TYPE, qos=topic_qos, key=None,
                        batches=self._receiver(topic, static),
                    )
                )  # fmt: skip
        except BaseException:
            self.unregister()
            raise

    def _authority(self, sample: Sample, topic: str) -> Authority:
        key = (sender_key(sample), topic)
        sender = self._senders.get(key)
        if sender is None:
            if len(self._senders) >= MAX_SENDERS:
                return key[0]
            sender = self._senders[key] = _Sender(self._context, key[0], topic, sample)
        return sender

    def _receiver(self, topic: str, static: bool) -> Callable[[list[Sample]], None]:
        def receive(samples: list[Sample]) -> None:
            self._on_samples(samples, topic, static)

        return receive

    def _clear_after_jump_back(self) -> None:
        """Clear the buffer if the clock went back since transforms last came: older stamps
        would otherwise be refused as old data until the clock caught up."""
        now = self._clock.now().nanoseconds
        with self._jump_lock:
            jumped = now < self._last_now - JUMP_BACK
            self._last_now = now
        if jumped:
            _log.warning('Detected jump back in time. Clearing tf buffer.')
            self.buffer.clear()

    def _on_samples(self, samples: list[Sample], topic: str, static: bool) -> None:
        self._clear_after_jump_back()
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
            if self._on_message is not None:
                try:
                    self._on_message(message, authority, static)
                except Exception:
                    _log.exception('on_message of the listener on %s raised', topic)

    def unregister(self) -> None:
        """Stop listening (the buffer keeps what it holds)."""
        for tap in self._taps:
            tap.close()
        self._taps.clear()

    close = unregister

    def __repr__(self) -> str:
        return f'<zros.tf.TransformListener on {", ".join(self.topics)}>'


class StaticTransformListener(TransformListener):
    """A listener of ``/tf_static`` alone (rclpy's): a buffer of the robot's fixed frames."""

    def __init__(
        self,
        buffer: Buffer,
        node: NodeLike | None = None,
        *,
        spin_thread: bool = False,
        static_qos: QoSLike | None = None,
        tf_static_topic: str = '/tf_static',
    ) -> None:
        super().__init__(
            buffer,
            node,
            spin_thread=spin_thread,
            static_qos=static_qos,
            tf_static_topic=tf_static_topic,
            static_only=True,
        )
