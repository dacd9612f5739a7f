"""``zros topic hz``, ``bw`` and ``delay`` (as ``ros2 topic``'s): a window of the last messages of
a topic, reported every period."""

from __future__ import annotations

import argparse
import itertools
import statistics
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

from zros.cli.graph_lookup import graph_topic_type, subscription_type
from zros.cli.shared import CommandError, message_class, open_node, out

if TYPE_CHECKING:
    from zros.cdr import Message
    from zros.node import Node


class _Window:
    """Arrival times (and sizes) of the last ``size`` messages."""

    def __init__(self, size: int) -> None:
        self.times: deque[float] = deque(maxlen=size)
        self.sizes: deque[int] = deque(maxlen=size)
        self.lock = threading.Lock()
        self.total = 0
        self._reported = 0  #: ``total`` at the last :meth:`take`

    def add(self, size: int) -> None:
        """Count one message of ``size`` bytes, arrived now."""
        now = time.monotonic()
        with self.lock:
            self.times.append(now)
            self.sizes.append(size)
            self.total += 1

    def take(self) -> tuple[list[float], list[int], bool]:
        """The window's arrival times and sizes, and whether any came since the last take."""
        with self.lock:
            fresh = self.total != self._reported
            self._reported = self.total
            return list(self.times), list(self.sizes), fresh


def _measuring_subscription(
    node: Node, args: argparse.Namespace, window: _Window
) -> Callable[[], object]:
    """A subscription counting the messages of ``args.topic`` into ``window``, announced like any
    other (node info, topic info -v and zros graph show it): messages stay undecoded bytes, and
    their time is taken when the node spins, as ros2 topic hz takes it in its callback.

    For a type zros has no definition of, it cannot announce the subscription (rmw_zenoh's keys
    need the type's hash): it listens on the topic's keys unannounced, and says so.
    Returns what closes it."""
    from zros.cdr.errors import UnknownTypeError
    from zros.pubsub import Subscriber
    from zros.pubsub.taps import RawTap
    from zros.qos import QoS, Reliability

    type_name = graph_topic_type(node, args.topic, args.wait)
    # as ros2's: best effort (it hears reliable publishers too), with room for bursts
    qos = QoS(1000, Reliability.BEST_EFFORT, lifespan=getattr(args, 'max_age', None))
    try:

        def count(data: bytes) -> None:
            window.add(len(data))

        return Subscriber(args.topic, type_name, count, qos, node=node, raw=True).close
    except UnknownTypeError:
        pass
    if qos.lifespan is not None:
        raise CommandError(
            f'--max-age needs the definition of {type_name} (ZROS_INTERFACE_PATH adds yours)'
        )
    wire = node.wire
    key = wire.any_type_key(wire.key(node.resolve_name(args.topic)))  # any type and hash
    print(
        f'zros: note: no definition of {type_name} (ZROS_INTERFACE_PATH adds yours): measuring '
        'without announcing the subscription',
        file=sys.stderr,
    )
    tap = RawTap(node, args.topic, type_name, qos=qos, key=key, announce=False,
                 callback=lambda sample: window.add(len(sample.payload)))  # fmt: skip
    return tap.close


def _report_loop(node: Node, args: argparse.Namespace, report: Callable[[], bool]) -> int:
    reports = 0
    try:
        while node.ok():
            node.spin(timeout=args.period)
            if report():
                reports += 1
                if args.count and reports >= args.count:
                    break
    except KeyboardInterrupt:
        pass
    return 0


def hz(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        window = _Window(args.window)
        close = _measuring_subscription(node, args, window)

        def report() -> bool:
            times, _, fresh = window.take()
            if len(times) < 2 or not fresh:  # as ros2's: not the last window again
                out('no new messages')
                return False
            gaps = [b - a for a, b in itertools.pairwise(times)]
            mean = statistics.fmean(gaps)
            deviation = statistics.pstdev(gaps)
            out(f'average rate: {1 / mean:.3f}')
            out(
                f'\tmin: {min(gaps):.3f}s max: {max(gaps):.3f}s std dev: {deviation:.5f}s '
                f'window: {len(times)}'
            )
            return True

        try:
            return _report_loop(node, args, report)
        finally:
            close()


def _size(value: float) -> str:
    for unit in ('B', 'KB', 'MB'):
        if value < 1000 or unit == 'MB':
            return f'{value:.0f} {unit}' if unit == 'B' else f'{value:.2f} {unit}'
        value /= 1000
    return f'{value:.2f} MB'


def bw(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        window = _Window(args.window)
        close = _measuring_subscription(node, args, window)
        out(f'Subscribed to [{node.resolve_name(args.topic)}]')

        def report() -> bool:
            times, sizes, _ = window.take()
            if len(times) < 2:
                return False
            # as ros2's: up to now, so the rate decays once the publisher stops
            span = max(time.monotonic() - times[0], 1e-9)
            rate = sum(sizes) / span
            out(f'{_size(rate)}/s from {len(sizes)} messages')
            out(
                f'\tMessage size mean: {_size(statistics.fmean(sizes))} min: {_size(min(sizes))} '
                f'max: {_size(max(sizes))}'
            )
            return True

        try:
            return _report_loop(node, args, report)
        finally:
            close()


def delay(args: argparse.Namespace) -> int:
    from zros.runtime.clock import Time

    with open_node(args) as node:
        type_name = subscription_type(node, args.topic, args.type, args.wait)
        if 'header' not in message_class(type_name).__slots__:
            raise CommandError(f'{type_name} has no header: its delay cannot be measured')
        delays: deque[float] = deque(maxlen=args.window)
        arrived = [0, 0]  # messages in all, and at the last report

        def on_message(message: Message) -> None:
            delays.append((node.now() - Time.from_msg(message.header.stamp)).seconds)
            arrived[0] += 1

        node.create_subscription(type_name, args.topic, on_message, qos='sensor_data')

        def report() -> bool:
            fresh, arrived[1] = arrived[0] != arrived[1], arrived[0]
            if not delays or not fresh:  # as ros2's: not the last window again
                out('no new messages')
                return False
            values = list(delays)
            out(f'average delay: {statistics.fmean(values):.3f}')
            out(
                f'\tmin: {min(values):.3f}s max: {max(values):.3f}s '
                f'std dev: {statistics.pstdev(values):.5f}s window: {len(values)}'
            )
            return True

        return _report_loop(node, args, report)
