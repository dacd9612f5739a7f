"""A zros node: a ROS name on the Zenoh network that owns publishers, subscribers and timers.

Zenoh delivers samples on its own threads; subscribers queue them as raw buffers and the node's
executor runs callbacks and timers on whichever thread calls :meth:`Node.spin_once` or
:meth:`Node.spin` (rosR's ``ros.SpinOnce``). Polling reads never need spinning.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import threading
import time
import weakref
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Any

from zros.keyexpr.bridge import BridgeScheme
from zros.keyexpr.names import (
    Remapping,
    expand,
    parse_ros_args,
    validate_namespace,
    validate_node_name,
)
from zros.qos import QoSLike
from zros.signal import Signal
from zros.timers import Rate, Timer
from zros.transport import Transport, TransportConfig, default_transport

if TYPE_CHECKING:
    from zros.cdr import Message, TypeRegistry
    from zros.pubsub import Publisher, Subscriber

#: set by zros.init's SIGINT handler: every node's ok() turns false
_interrupted = threading.Event()
_nodes: weakref.WeakSet[Node] = weakref.WeakSet()


def wake_all_nodes() -> None:
    """Make every node's waiting spin return (after Ctrl-C)."""
    for node in list(_nodes):
        node._executor.wake()


class Executor:
    """The callback queue of one node: subscribers with unread messages, and timers."""

    def __init__(self) -> None:
        self._ready: collections.deque[Subscriber] = collections.deque()
        self._signal = Signal()
        self._timers: list[Timer] = []
        self._async_wakers: list[Callable[[], None]] = []
        self.stopped = False

    # called on Zenoh threads: keep it cheap
    def schedule(self, subscriber: Subscriber) -> None:
        if not subscriber._scheduled:
            subscriber._scheduled = True
            self._ready.append(subscriber)
            self._wake()

    def _wake(self) -> None:
        if self._signal:
            self._signal.notify()
        for waker in self._async_wakers:
            waker()

    def wake(self) -> None:
        """Make a waiting ``run_once`` return (shutdown, Ctrl-C)."""
        self._signal.notify()
        for waker in self._async_wakers:
            waker()

    def add_timer(self, timer: Timer) -> None:
        self._timers.append(timer)
        self.wake()

    def remove_timer(self, timer: Timer) -> None:
        if timer in self._timers:
            self._timers.remove(timer)

    def _has_work(self) -> bool:
        return bool(self._ready) or self.stopped or _interrupted.is_set()

    def _run_ready(self) -> int:
        done = 0
        while self._ready:
            subscriber = self._ready.popleft()
            subscriber._scheduled = False
            done += subscriber._dispatch()
        return done

    def _run_timers(self) -> int:
        done = 0
        now = time.monotonic()
        for timer in list(self._timers):
            if timer.time_until_due(now) <= 0 and not timer.cancelled:
                timer._fire(now)
                done += 1
        return done

    def _next_timer(self) -> float | None:
        now = time.monotonic()
        return min((t.time_until_due(now) for t in self._timers), default=None)

    def run_once(self, timeout: float | None) -> int:
        """Run what is due; wait up to ``timeout`` seconds (None: forever) for something to do."""
        done = self._run_ready() + self._run_timers()
        if done or (timeout is not None and timeout <= 0):
            return done
        deadline = None if timeout is None else time.monotonic() + timeout
        while not (self.stopped or _interrupted.is_set()):
            wait: float | None = None if deadline is None else deadline - time.monotonic()
            next_timer = self._next_timer()
            if next_timer is not None:
                wait = next_timer if wait is None else min(wait, next_timer)
            if wait is None or wait > 0:
                self._signal.wait(self._has_work, wait)
            done = self._run_ready() + self._run_timers()
            if done or (deadline is not None and time.monotonic() >= deadline):
                return done
        return 0


class Node:
    """A ROS node on the Zenoh network.

    ``namespace`` is the node's own namespace (relative topic names resolve into it);
    ``bridge_namespace`` is the ``namespace`` setting of the zenoh-bridge-ros2dds to reach, which
    prefixes every Zenoh key. ``args`` takes a command line with ``--ros-args -r from:=to``
    remappings (``__node``, ``__ns`` too). Without ``transport``, the node uses the process's
    session, opened from ``connect``/``config`` or the environment (see ``zros.transport``).
    """

    def __init__(
        self,
        name: str,
        namespace: str = '/',
        *,
        transport: Transport | None = None,
        connect: str | Sequence[str] | None = None,
        config: TransportConfig | None = None,
        registry: TypeRegistry | None = None,
        bridge_namespace: str = '/',
        remap: Iterable[str] | dict[str, str] | None = None,
        args: Sequence[str] | None = None,
    ) -> None:
        remapping = Remapping.parse(remap or ())
        if args is not None:
            from_args, _ = parse_ros_args(args)
            remapping = Remapping(
                remapping.rules + from_args.rules,
                from_args.node_name or remapping.node_name,
                from_args.namespace or remapping.namespace,
            )
        self.name = remapping.node_name or name
        self.namespace = remapping.namespace or namespace
        validate_node_name(self.name)
        validate_namespace(self.namespace)
        self.remapping = remapping
        if transport is None:
            if config is None and connect is not None:
                config = TransportConfig.create(connect=connect)
            transport = default_transport(config)
        self.transport = transport
        if registry is None:
            from zros.cdr import default_registry

            registry = default_registry()
        self.registry = registry
        self.scheme = BridgeScheme(bridge_namespace)
        self._executor = Executor()
        self._entities: list[Any] = []
        self._closed = False
        transport.on_close(self.destroy)
        _nodes.add(self)

    # --- names ---------------------------------------------------------------------------

    @property
    def fully_qualified_name(self) -> str:
        """``/namespace/name`` of this node."""
        return self.namespace.rstrip('/') + '/' + self.name

    def resolve_name(self, name: str, kind: str = 'topic name') -> str:
        """The fully qualified form of a topic or service name, remappings applied."""
        full = expand(name, self.name, self.namespace, kind)
        return self.remapping.apply(full, self.name, self.namespace)

    # --- entities ------------------------------------------------------------------------

    def create_publisher(
        self, msg_type: str | type[Message], topic: str, qos: QoSLike | None = None
    ) -> Publisher:
        """A publisher on ``topic`` (argument order of rclpy)."""
        from zros.pubsub import Publisher

        return Publisher(topic, msg_type, qos, node=self)

    def create_subscription(
        self,
        msg_type: str | type[Message],
        topic: str,
        callback: Callable[[Any], object] | None = None,
        qos: QoSLike | None = None,
    ) -> Subscriber:
        """A subscriber on ``topic``; ``callback(message)`` runs when the node spins."""
        from zros.pubsub import Subscriber

        return Subscriber(topic, msg_type, callback, qos, node=self)

    def create_timer(self, period: float, callback: Callable[[], object]) -> Timer:
        """A timer calling ``callback()`` every ``period`` seconds while the node spins."""
        self._check_open()
        return Timer(self, period, callback)

    def create_rate(self, hz: float) -> Rate:
        """A rate whose ``sleep()`` runs this node's callbacks while it waits."""
        return Rate(hz, self)

    def _add(self, entity: Any) -> None:
        self._check_open()
        self._entities.append(entity)

    def _remove(self, entity: Any) -> None:
        if entity in self._entities:
            self._entities.remove(entity)

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError(f'node {self.fully_qualified_name} was destroyed')

    # --- spinning ------------------------------------------------------------------------

    def ok(self) -> bool:
        """True until the node is destroyed or the process got Ctrl-C (after ``zros.init``)."""
        return not (self._closed or _interrupted.is_set())

    def spin_once(self, timeout: float | None = 0.0) -> int:
        """Run due callbacks and timers, waiting up to ``timeout`` seconds for one; returns how
        many ran. ``timeout=None`` waits until something runs."""
        return self._executor.run_once(timeout)

    def spin(self, timeout: float | None = None) -> None:
        """Run callbacks and timers until the node stops being ok (or ``timeout`` seconds)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.ok():
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return
            self._executor.run_once(remaining)

    def spin_until(self, deadline: float) -> None:
        """Run callbacks and timers until ``time.monotonic()`` reaches ``deadline``."""
        while self.ok():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return
            self._executor.run_once(remaining)

    async def spin_async(self) -> None:
        """Run callbacks and timers on the asyncio loop until the node stops being ok."""
        loop = asyncio.get_running_loop()
        event = asyncio.Event()

        def waker() -> None:
            loop.call_soon_threadsafe(event.set)

        self._executor._async_wakers.append(waker)
        try:
            while self.ok():
                event.clear()
                if self._executor.run_once(0):
                    await asyncio.sleep(0)
                    continue
                next_timer = self._executor._next_timer()
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(event.wait(), next_timer)
        finally:
            self._executor._async_wakers.remove(waker)

    # --- lifetime --------------------------------------------------------------------------

    def destroy(self) -> None:
        """Undeclare every publisher, subscriber and timer of the node; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self._executor.stopped = True
        for entity in list(reversed(self._entities)):
            entity.close()
        self._entities.clear()
        for timer in list(self._executor._timers):
            timer.cancel()
        self._executor.wake()

    close = destroy

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()

    def __repr__(self) -> str:
        state = ' (destroyed)' if self._closed else ''
        return f'<zros Node {self.fully_qualified_name}{state}>'
