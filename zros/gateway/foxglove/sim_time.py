"""The live gateway's sim time: ``/clock`` followed over Zenoh."""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

from zros.cdr import CdrError
from zros.cdr.message import decode
from zros.pubsub.taps import RawTap
from zros.qos import QoS, Reliability

if TYPE_CHECKING:
    import zenoh

    from zros.node import Node

_log = logging.getLogger('zros.gateway')


def follow_clock(node: Node, on_time: Callable[[int], None]) -> RawTap:
    """A tap on ``/clock`` handing each message's time in ns to ``on_time`` (a message that
    does not decode is logged, at debug level, and skipped); ``close()`` it."""
    cls = node.registry.get_class('rosgraph_msgs/msg/Clock')

    def on_clock(sample: zenoh.Sample) -> None:
        try:
            clock = decode(cls, sample.payload.to_bytes()).clock
        except CdrError as exc:
            _log.debug('a /clock message does not decode: %s', exc)
            return
        on_time(clock.sec * 1_000_000_000 + clock.nanosec)

    return RawTap(
        node,
        '/clock',
        cls.__msgtype__,
        qos=QoS(1, Reliability.BEST_EFFORT),
        key=None,
        callback=on_clock,
    )
