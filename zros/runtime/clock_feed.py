"""What moves a node's sim clock: its subscription to ``/clock``."""

from __future__ import annotations

import logging

from zenoh import Sample

from zros.cdr import CdrError, decode
from zros.cdr.registry import registry_of
from zros.keyexpr.kinds import EntityKind
from zros.qos import QoS, Reliability
from zros.runtime.clock import SimClock, Time
from zros.runtime.defaults import NodeLike
from zros.runtime.entity import Entity

_log = logging.getLogger('zros')


class ClockSubscription(Entity):
    """Feeds a SimClock from ``/clock``, decoding on Zenoh's thread so time moves without spin;
    each move wakes the node's executor (its timers follow sim time)."""

    def __init__(self, node: NodeLike, clock: SimClock) -> None:
        super().__init__(node)
        self.clock = clock
        self._cls = self.context.registry.get_class('rosgraph_msgs/msg/Clock')
        qos = QoS(1, Reliability.BEST_EFFORT)
        # announced as the bridge's own subscriber: no zros node owns it
        wire = self._place(
            EntityKind.SUBSCRIBER, '/clock', self._cls.__msgtype__, registry_of(self._cls),
            qos=qos, owned=False,
        )  # fmt: skip
        self.key = wire.key
        self._subscribe(wire, qos, self._on_sample)
        self._wake = self.context.executor.wake
        clock.add_listener(self._wake)
        self._announce()

    def _on_sample(self, sample: Sample) -> None:
        try:
            message = decode(self._cls, sample.payload.to_bytes())
        except CdrError as exc:  # a malformed /clock message leaves the clock where it is
            _log.debug('dropped a /clock message that does not decode: %s', exc)
            return
        self.clock.set(Time.from_msg(message.clock))

    def _on_close(self) -> None:
        self.clock.remove_listener(self._wake)
