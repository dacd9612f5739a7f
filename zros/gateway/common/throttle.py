"""Per-topic rate limits on what a gateway sends its clients: ``--throttle '/camera/.*=2'``.

A rule is a Python regular expression of topic names (whole names, as ``--topics``) and the
most messages a second its topics send; the first rule that matches a topic applies. A
throttled topic passes a message when its next turn is due and drops the others: at 2 Hz, a
10 Hz camera sends every fifth frame, the newest at that moment. The limit is the topic's, for
all its clients together (the gateway receives each topic once). It saves what crosses the
gateway's link (and the client's CPU); the robot still publishes at its rate.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable, Iterable
from typing import TypeVar

from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import compile_regex

_T = TypeVar('_T')


class Throttle:
    """Rate limits by topic name (``rules``: pairs of a whole-name pattern and a rate in Hz)."""

    def __init__(self, rules: Iterable[tuple[str, float]] = ()) -> None:
        self.rules: list[tuple[re.Pattern[str], float]] = []
        for pattern, rate in rules:
            compiled = compile_regex(pattern, f'--throttle {pattern!r}: not a regular expression')
            if not rate > 0:
                raise GatewayError(f'--throttle {pattern!r}: the rate must be > 0 Hz, not {rate}')
            self.rules.append((compiled, float(rate)))

    @classmethod
    def parse(cls, specs: Iterable[str]) -> Throttle:
        """Rules from ``REGEX=HZ`` texts (GatewayError naming a wrong one)."""
        rules = []
        for spec in specs:
            pattern, _, rate = spec.rpartition('=')
            try:
                hz = float(rate)
            except ValueError:
                hz = 0.0
            if not pattern or not hz > 0:
                raise GatewayError(
                    f"--throttle takes REGEX=HZ with HZ > 0, as '/camera/.*=2', not {spec!r}"
                )
            rules.append((pattern, hz))
        return cls(rules)

    def rate(self, topic: str) -> float | None:
        """The most messages a second ``topic`` sends (None: no limit)."""
        for pattern, rate in self.rules:
            if pattern.fullmatch(topic):
                return rate
        return None

    def limit(
        self,
        topic: str,
        deliver: Callable[[_T, int], object],
        clock: Callable[[], float] = time.monotonic,
    ) -> Callable[[_T, int], object]:
        """``deliver`` (a gateway's ``(data, stamp)`` callback), passing at most
        :meth:`rate` messages of ``topic`` a second; ``deliver`` itself where none applies."""
        rate = self.rate(topic)
        if rate is None:
            return deliver
        period = 1.0 / rate
        due = [float('-inf')]  #: when the next message may pass
        lock = threading.Lock()

        def throttled(data: _T, stamp: int) -> object:
            now = clock()
            with lock:
                if now < due[0]:
                    return None
                # on schedule: keep it (the average rate holds); behind by more: start again
                due[0] = due[0] + period if now - due[0] < period else now + period
            return deliver(data, stamp)

        return throttled

    def __repr__(self) -> str:
        rules = ', '.join(f'{p.pattern}={r:g}' for p, r in self.rules)
        return f'<Throttle {rules or "none"}>'
