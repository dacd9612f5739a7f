"""What tf2_monitor reports: how late transforms arrive (their arrival time less their stamp),
per frame and per broadcaster, each broadcaster's rate, and a chain's net delay.

Fed by :class:`~zros.tf.listener.TransformListener`'s ``on_message``, on the delivery thread;
every table keeps the newest :data:`WINDOW` values and at most :data:`MAX_FRAMES` frames, so a
monitor left running does not grow.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable

from zros.cdr import Message
from zros.tf.checks import Authority
from zros.tf.edge_tree import MAX_FRAMES

_NS = 1_000_000_000
#: values kept per frame and per broadcaster (tf2_monitor's 1000)
WINDOW = 1000


class _Delays:
    """The newest delays (seconds) of a frame, a broadcaster or a chain."""

    __slots__ = ('arrivals', 'values')

    def __init__(self) -> None:
        self.values: deque[float] = deque(maxlen=WINDOW)
        self.arrivals: deque[float] = deque(maxlen=WINDOW)  #: seconds, monotonic

    def add(self, delay: float, arrival: float) -> None:
        self.values.append(delay)
        self.arrivals.append(arrival)

    def stats(self) -> tuple[str, str]:
        """The average and the largest, as tf2_monitor prints them ('-' without values)."""
        values = list(self.values)
        if not values:
            return '-', '-'
        return f'{sum(values) / len(values):.6g}', f'{max(values):.6g}'

    def text(self) -> str:
        average, largest = self.stats()
        return f'Average Delay: {average} Max Delay: {largest}'

    def rate(self) -> float:
        """Arrivals per second over the window (0 with fewer than two)."""
        arrivals = list(self.arrivals)
        if len(arrivals) < 2 or arrivals[-1] <= arrivals[0]:
            return 0.0
        return (len(arrivals) - 1) / (arrivals[-1] - arrivals[0])


class DelayMonitor:
    """Delays of the transforms a listener hands to :meth:`record` (its ``on_message``).
    Senders are named when the report is made (the graph may learn of one after its data)."""

    def __init__(self, now: Callable[[], int] = time.time_ns) -> None:
        self._now = now  #: the clock the stamps are compared with (ns)
        self._lock = threading.Lock()
        self._frames: dict[str, _Delays] = {}
        self._publishers: dict[str, Authority] = {}  #: frame -> its newest broadcaster
        self._static: set[str] = set()
        self._broadcasters: dict[Authority, _Delays] = {}
        self._static_broadcasters: set[Authority] = set()
        self.chain = _Delays()  #: :meth:`sample_chain`'s delays

    def record(self, message: Message, authority: Authority, static: bool) -> None:
        """One ``TFMessage`` as it arrived from ``authority``."""
        now = self._now()
        arrival = time.monotonic()
        with self._lock:
            if static:
                for transform in message.transforms:
                    frame = transform.child_frame_id.lstrip('/')
                    if frame in self._publishers or len(self._publishers) < MAX_FRAMES:
                        self._static.add(frame)
                        self._publishers[frame] = authority
                if len(self._static_broadcasters) < MAX_FRAMES:
                    self._static_broadcasters.add(authority)
                return
            total = 0.0
            for transform in message.transforms:
                stamp = transform.header.stamp
                delay = (now - stamp.sec * _NS - stamp.nanosec) / _NS
                total += delay
                frame = transform.child_frame_id.lstrip('/')
                delays = self._frames.get(frame)
                if delays is None:
                    if len(self._publishers) >= MAX_FRAMES:
                        continue
                    delays = self._frames[frame] = _Delays()
                self._static.discard(frame)
                self._publishers[frame] = authority
                delays.add(delay, arrival)
            broadcaster = self._broadcasters.get(authority)
            if broadcaster is None:
                if len(self._broadcasters) >= MAX_FRAMES:
                    return
                broadcaster = self._broadcasters[authority] = _Delays()
            broadcaster.add(total / max(1, len(message.transforms)), arrival)

    def sample_chain(self, stamp: int) -> None:
        """The stamp of a chain's latest transform, looked up now (0, a static chain: none)."""
        if stamp:
            self.chain.add((self._now() - stamp) / _NS, time.monotonic())

    def report(self, chain: list[str] | None = None) -> str:
        """tf2_monitor's text: the chain's net delay (when given: its frames, source first),
        every frame (of the chain) and every broadcaster."""
        lines = []
        if chain is None:
            lines.append('RESULTS: for all Frames')
        else:
            lines += [
                f'RESULTS: for {chain[-1]} to {chain[0]}',
                f'Chain is: {" -> ".join(reversed(chain))}',
                'Net delay     avg = {}: max = {}'.format(*self.chain.stats()),
            ]
        lines += ['', 'Frames:']
        with self._lock:
            for frame in sorted(self._publishers):
                if chain is not None and frame not in chain:
                    continue
                head = f'Frame: {frame} published by {self._publishers[frame]}'
                if frame in self._static:
                    lines.append(f'{head} (static)')
                elif frame in self._frames:
                    lines.append(f'{head} {self._frames[frame].text()}')
            lines += ['', 'All Broadcasters:']
            senders = self._broadcasters.keys() | self._static_broadcasters
            named = sorted(((str(sender), sender) for sender in senders), key=lambda pair: pair[0])
            for name, sender in named:
                delays = self._broadcasters.get(sender)
                if delays is None:
                    lines.append(f'Node: {name} static')
                else:
                    lines.append(f'Node: {name} {delays.rate():.4g} Hz, {delays.text()}')
        return '\n'.join(lines)
