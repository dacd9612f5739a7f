"""Broadcasters: transforms onto ``/tf`` and latched ones onto ``/tf_static``."""

from __future__ import annotations

from collections.abc import Iterable

from zros.cdr import Message
from zros.pubsub import Publisher
from zros.qos import Durability, QoS
from zros.runtime.defaults import NodeLike, default_node

TF_TYPE = 'tf2_msgs/msg/TFMessage'
#: tf2_ros's broadcaster QoS: reliable, volatile, keep last 100
BROADCASTER_QOS = QoS(100)
#: tf2_ros's static broadcaster QoS: reliable, transient local, keep last 1
STATIC_BROADCASTER_QOS = QoS(1, durability=Durability.TRANSIENT_LOCAL)


def _as_list(transform: Message | Iterable[Message]) -> list[Message]:
    if isinstance(transform, Message):
        return [transform]
    return list(transform)


class TransformBroadcaster:
    """Publishes ``geometry_msgs/msg/TransformStamped`` messages on ``/tf``."""

    def __init__(self, node: NodeLike | None = None, qos: QoS = BROADCASTER_QOS) -> None:
        self.node = node if node is not None else default_node()
        self.publisher = Publisher('/tf', TF_TYPE, qos, node=self.node)
        self._message_class = self.publisher.msg_type

    def send_transform(self, transform: Message | Iterable[Message]) -> None:
        """Publish one transform or several in one message."""
        self.publisher.write(self._message_class(transforms=_as_list(transform)))

    sendTransform = send_transform  # noqa: N815 (tf2_ros's name)

    def close(self) -> None:
        """Stop publishing."""
        self.publisher.close()


class StaticTransformBroadcaster:
    """Publishes transforms valid at every time on the latched ``/tf_static``: listeners that
    start later get them. Each call adds to what it holds (replacing a child frame's earlier
    transform) and publishes all of them, as tf2's does."""

    def __init__(self, node: NodeLike | None = None, qos: QoS = STATIC_BROADCASTER_QOS) -> None:
        self.node = node if node is not None else default_node()
        self.publisher = Publisher('/tf_static', TF_TYPE, qos, node=self.node)
        self._message_class = self.publisher.msg_type
        self._held: dict[str, Message] = {}

    def send_transform(self, transform: Message | Iterable[Message]) -> None:
        """Add transforms to the ones held and publish them all."""
        for one in _as_list(transform):
            self._held[one.child_frame_id] = one
        self.publisher.write(self._message_class(transforms=list(self._held.values())))

    sendTransform = send_transform  # noqa: N815 (tf2_ros's name)

    def close(self) -> None:
        """Stop publishing (late joiners no longer get the transforms)."""
        self.publisher.close()
