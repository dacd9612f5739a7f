"""A node's ``/rosout``: the sink its loggers publish records into (``rcl_interfaces/msg/Log``)."""

from __future__ import annotations

import logging
import threading

from zros.cdr.message import Message
from zros.pubsub.publisher import Publisher
from zros.qos import ROSOUT
from zros.runtime.defaults import NodeLike
from zros.runtime.logger import RosoutRecord

_log = logging.getLogger('zros')


class RosoutSink:
    """Publishes a node's log records on ``/rosout`` (reliable, transient local, depth 1000;
    the publisher is made on first use); ``enabled`` False keeps them on the console."""

    def __init__(self, node: NodeLike, level: int, enabled: bool = True) -> None:
        self._node = node
        self._context = node.context
        self._level = level
        self.enabled = enabled
        self._publisher: Publisher[Message] | None = None
        self._lock = threading.Lock()

    @property
    def level(self) -> int:
        """The node's threshold."""
        return self._level

    def stamp(self) -> int:
        """Nanoseconds of the node's clock now."""
        return self._context.clock.now().nanoseconds

    def publish(self, record: RosoutRecord) -> None:
        """Publish ``record`` (nothing once the node is destroyed or with rosout disabled)."""
        if not self.enabled or self._context.closed:
            return
        try:
            with self._lock:
                if self._publisher is None:
                    self._publisher = Publisher(
                        '/rosout', 'rcl_interfaces/msg/Log', ROSOUT, node=self._node
                    )
            publisher = self._publisher
            message = publisher.msg_type(
                level=record.level,
                name=record.name,
                msg=record.msg,
                file=record.file,
                function=record.function,
                line=record.line,
            )
            message.stamp.sec, message.stamp.nanosec = divmod(record.stamp, 1_000_000_000)
            publisher.write(message)
        except Exception:  # logging must never break the program that logs
            _log.debug('cannot publish on /rosout', exc_info=True)
