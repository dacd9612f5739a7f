"""A zros node: a ROS name on the Zenoh network that owns publishers, subscribers and timers.

Zenoh delivers samples on its own threads; subscribers queue them as raw buffers and the node's
executor runs callbacks and timers on whichever thread calls :meth:`Node.spin_once` or
:meth:`Node.spin` (rosR's ``ros.SpinOnce``). Polling reads never need spinning.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import contextlib
import logging
import os
import threading
import time
import weakref
from collections.abc import Callable, Coroutine, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from zros.graph import Graph
from zros.keyexpr.bridge import BridgeScheme
from zros.keyexpr.names import (
    Remapping,
    expand,
    parse_ros_args,
    validate_namespace,
    validate_node_name,
)
from zros.keyexpr.owners import node_token
from zros.keyexpr.rmw_zenoh import NodeToken, RmwZenohScheme
from zros.qos import QoSLike
from zros.runtime.clock import (
    Clock,
    ClockSubscription,
    SimClock,
    Time,
    use_sim_time_from_environment,
)
from zros.runtime.logger import (
    INFO,
    Logger,
    RosoutRecord,
    level_from_environment,
    logger_name,
    parse_level,
)
from zros.runtime.signal import Signal, interrupted
from zros.runtime.timers import Rate, Timer
from zros.transport import Transport, TransportConfig, default_transport

if TYPE_CHECKING:
    from zros.actions import ActionClient, ActionServer, ServerGoalHandle
    from zros.cdr import Message, TypeRegistry
    from zros.cdr.interfaces import ActionType, ServiceType
    from zros.params import Descriptor, ParameterClient, SetResult
    from zros.params.server import ParameterServer
    from zros.pubsub import Publisher, Subscriber
    from zros.services import Client, Service

T = TypeVar('T')
_nodes: weakref.WeakSet[Node] = weakref.WeakSet()


def _parameter_overrides(
    node_fqn: str,
    parameters: Mapping[str, Any] | None,
    params_files: str | os.PathLike[str] | Sequence[str | os.PathLike[str]] | None,
    ros_args: Any,
) -> dict[str, Any]:
    """A node's parameter values from code, files and ``-p`` (later ones win)."""
    from zros.params import files

    overrides = dict(parameters or {})
    if params_files is None:
        paths: list[str | os.PathLike[str]] = []
    elif isinstance(params_files, (str, os.PathLike)):
        paths = [params_files]
    else:
        paths = list(params_files)
    for path in [*paths, *ros_args.params_files]:
        overrides.update(files.values_for(files.load_file(path), node_fqn))
    node_name = node_fqn.rpartition('/')[2]
    for name, text in ros_args.parameters.items():
        target, colon, parameter = name.rpartition(':')
        if colon and target not in (node_name, node_fqn, node_fqn.lstrip('/')):
            continue  # -p other_node:name:=value
        overrides[parameter] = files.parse_override(f'{parameter}:={text}')[1]
    return overrides


def _domain_id(value: int | None) -> int:
    """The ROS domain: ``value``, else ``ROS_DOMAIN_ID``, else 0."""
    if value is None:
        text = os.environ.get('ROS_DOMAIN_ID', '').strip()
        if not text:
            return 0
        if not text.isdigit():
            raise ValueError(f'ROS_DOMAIN_ID must be a non-negative integer, not {text!r}')
        value = int(text)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ValueError(f'a ROS domain id is a non-negative integer, not {value!r}')
    return value


def wake_all_nodes() -> None:
    """Make every node's waiting spin return (after Ctrl-C)."""
    for node in list(_nodes):
        node._executor.wake()


class _Call:
    """A function queued to run once on the spinning thread."""

    __slots__ = ('_scheduled', 'function')

    def __init__(self, function: Callable[[], object]) -> None:
        self.function = function
        self._scheduled = True

    def _dispatch(self) -> int:
        try:
            self.function()
        except Exception:
            logging.getLogger('zros').exception('callback %r raised', self.function)
        return 1


class Executor:
    """The callback queue of one node: entities with work to do (unread messages, requests,
    queued calls), and timers."""

    def __init__(self) -> None:
        self._ready: collections.deque[Any] = collections.deque()
        self._signal = Signal()
        self._timers: list[Timer] = []
        self._async_wakers: list[Callable[[], None]] = []
        self._woken = False  #: wake() was called: a waiting run_once returns even with no work
        self.stopped = False

    # called on Zenoh threads: keep it cheap
    def schedule(self, entity: Any) -> None:
        """Queue ``entity._dispatch()`` (a subscriber, a service...) unless already queued."""
        if not entity._scheduled:
            entity._scheduled = True
            self._ready.append(entity)
            self._wake()

    def call_soon(self, function: Callable[[], object]) -> None:
        """Run ``function()`` on the spinning thread (thread-safe)."""
        self._ready.append(_Call(function))
        self._wake()

    def _wake(self) -> None:
        if self._signal:
            self._signal.notify()
        for waker in self._async_wakers:
            waker()

    def wake(self) -> None:
        """Make a waiting ``run_once`` return (shutdown, Ctrl-C, the sim clock moved)."""
        self._woken = True
        self._signal.notify()
        for waker in self._async_wakers:
            waker()

    def add_timer(self, timer: Timer) -> None:
        """Run ``timer`` when it is due."""
        self._timers.append(timer)
        self.wake()

    def remove_timer(self, timer: Timer) -> None:
        """Stop running ``timer``."""
        if timer in self._timers:
            self._timers.remove(timer)

    def _has_work(self) -> bool:
        return bool(self._ready) or self._woken or self.stopped or interrupted()

    def _run_ready(self) -> int:
        done = 0
        while self._ready:
            entity = self._ready.popleft()
            entity._scheduled = False
            done += entity._dispatch()
        return done

    def _run_timers(self) -> int:
        done = 0
        for timer in list(self._timers):
            wait = timer.seconds_until_due()
            if wait is not None and wait <= 0 and not timer.cancelled:
                timer._fire()
                done += 1
        return done

    def _next_timer(self) -> float | None:
        waits = [w for w in (t.seconds_until_due() for t in self._timers) if w is not None]
        return min(waits, default=None)

    def run_once(self, timeout: float | None) -> int:
        """Run what is due; wait up to ``timeout`` seconds (None: forever) for something to do."""
        done = self._run_ready() + self._run_timers()
        if done or (timeout is not None and timeout <= 0):
            return done
        deadline = None if timeout is None else time.monotonic() + timeout
        while not (self.stopped or interrupted()):
            wait: float | None = None if deadline is None else deadline - time.monotonic()
            next_timer = self._next_timer()
            if next_timer is not None:
                wait = next_timer if wait is None else min(wait, next_timer)
            if wait is None or wait > 0:
                self._signal.wait(self._has_work, wait, interruptible=True)
            done = self._run_ready() + self._run_timers()
            woken, self._woken = self._woken, False
            if done or woken or (deadline is not None and time.monotonic() >= deadline):
                return done
        return 0


class Node:
    """A ROS node on the Zenoh network.

    ``namespace`` is the node's own namespace (relative topic names resolve into it);
    ``bridge_namespace`` is the ``namespace`` setting of the zenoh-bridge-ros2dds to reach, which
    prefixes every Zenoh key; by default the namespace the bridges present report (``/`` when
    none answers at creation). ``args`` takes a command line with ``--ros-args`` (remappings
    ``-r from:=to``, ``__node``, ``__ns``, ``-p use_sim_time:=true``, ``--log-level``). Without
    ``transport``, the node uses the process's session, opened from ``connect``/``config``, the
    other settings of ``TransportConfig.create`` (``mode``, ``tls``, ``user``, ``password``, ...)
    or the environment (see ``zros.transport``).

    ``use_sim_time`` (also ``ZROS_USE_SIM_TIME=1``) makes the node's clock, timers and rates
    follow ``/clock``. ``log_level`` (also ``ZROS_LOG_LEVEL``) is the threshold of its logger;
    ``enable_rosout`` publishes its log records on ``/rosout``.

    Parameters get their values, lowest priority first, from ``parameters``, the files of
    ``params_file`` and ``--params-file``, and ``-p name:=value``; with
    ``allow_undeclared_parameters`` those are declared at once and clients may set new names.
    ``start_parameter_services`` serves them to ROS tools.

    ``wire`` picks the key scheme: ``'bridge'`` (zenoh-bridge-ros2dds, the default) or
    ``'rmw_zenoh'`` (ROS 2 nodes running rmw_zenoh, no bridge), also from ``ZROS_WIRE``; under
    rmw_zenoh ``domain_id`` (default ``ROS_DOMAIN_ID``, else 0) is the ROS domain.
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
        bridge_namespace: str | None = None,
        remap: Iterable[str] | dict[str, str] | None = None,
        args: Sequence[str] | None = None,
        use_sim_time: bool | None = None,
        log_level: str | int | None = None,
        enable_rosout: bool = True,
        parameters: Mapping[str, Any] | None = None,
        params_file: str | os.PathLike[str] | Sequence[str | os.PathLike[str]] | None = None,
        allow_undeclared_parameters: bool = False,
        start_parameter_services: bool = True,
        wire: str | None = None,
        domain_id: int | None = None,
        **settings: Any,
    ) -> None:
        remapping = Remapping.parse(remap or ())
        ros_args = parse_ros_args(args or ())
        remapping = Remapping(
            remapping.rules + ros_args.remapping.rules,
            ros_args.remapping.node_name or remapping.node_name,
            ros_args.remapping.namespace or remapping.namespace,
        )
        self.name = remapping.node_name or name
        self.namespace = remapping.namespace or namespace
        validate_node_name(self.name)
        validate_namespace(self.namespace)
        overrides = _parameter_overrides(
            self.fully_qualified_name, parameters, params_file, ros_args
        )
        if use_sim_time is None:
            if 'use_sim_time' in overrides:
                use_sim_time = overrides['use_sim_time'] is True
            else:
                use_sim_time = use_sim_time_from_environment()
        self.remapping = remapping
        from zros.wire import check_wire

        self.wire = check_wire(wire or os.environ.get('ZROS_WIRE') or 'bridge')
        if transport is None:
            if config is None and (connect is not None or settings or wire is not None):
                config = TransportConfig.create(connect=connect, wire=self.wire, **settings)
            elif settings:
                raise TypeError(f'give settings {sorted(settings)} in config=, not beside it')
            transport = default_transport(config)
        elif settings or connect is not None or config is not None:
            raise TypeError('a node given a transport= takes no connection settings')
        self.transport = transport
        if registry is None:
            from zros.cdr import default_registry

            registry = default_registry()
        self.registry = registry
        self.scheme: BridgeScheme | RmwZenohScheme
        self._wire_node: NodeToken | None = None  #: rmw_zenoh: the node's id and names
        if self.wire == 'rmw_zenoh':
            if bridge_namespace is not None:
                raise TypeError("bridge_namespace= is for wire='bridge'")
            self.scheme = RmwZenohScheme(_domain_id(domain_id), humble=registry.distro == 'humble')
            self._wire_node = self.scheme.node(
                transport.zid, transport.next_entity_id(), self.namespace, self.name
            )
        else:
            if domain_id is not None:
                raise TypeError("domain_id= is for wire='rmw_zenoh' (bridges set their own)")
            self.scheme = self._bridge_scheme(transport, bridge_namespace)
        self._executor = Executor()
        self._spin_loop: asyncio.AbstractEventLoop | None = None  #: the loop of spin_async
        self._own_loop: asyncio.AbstractEventLoop | None = None  #: async callbacks otherwise
        self._loop_lock = threading.Lock()
        self._entities: list[Any] = []
        self._closed = False
        self._log_level = parse_level(
            log_level
            if log_level is not None
            else (ros_args.log_level or level_from_environment() or INFO)
        )
        self._enable_rosout = enable_rosout
        self._rosout: Publisher | None = None
        self._rosout_lock = threading.Lock()
        self._logger = Logger(logger_name(self.name, self.namespace), self)
        self._clock_subscription: ClockSubscription | None = None
        if use_sim_time:
            sim = SimClock()
            self.clock: Clock = sim
            self._clock_subscription = ClockSubscription(self, sim)
            sim.add_listener(self._executor.wake)
        else:
            self.clock = Clock()
        if self._wire_node is not None:
            self._node_token = self._wire_node.format()
        else:
            self._node_token = node_token(transport.zid, self.fully_qualified_name)
        transport.declare_token(self._node_token)
        transport.on_close(self.destroy)
        _nodes.add(self)
        from zros.params import ParameterStore

        self.parameters = ParameterStore(
            self.fully_qualified_name, overrides, allow_undeclared_parameters
        )
        self._parameter_server: ParameterServer | None = None
        if start_parameter_services:
            from zros.params.server import ParameterServer

            self._parameter_server = ParameterServer(self, self.parameters)
        if not self.parameters.has('use_sim_time'):
            self.parameters.declare('use_sim_time', bool(use_sim_time))
        self.parameters.add_on_set_callback(self._refuse_sim_time_switch, internal=True)

    @staticmethod
    def _bridge_scheme(transport: Transport, namespace: str | None) -> BridgeScheme:
        """Keys for the bridges present: their namespace, and the type hash if they take it."""
        bridges = transport.bridges_at_start()
        versions = [bridge.version_tuple for bridge in bridges.values()]
        send_type_hash = bool(versions) and all(v is not None and v >= (1, 0, 4) for v in versions)
        if namespace is None:
            found = {bridge.namespace for bridge in bridges.values() if bridge.namespace}
            namespace = found.pop() if len(found) == 1 else '/'
            if found:
                logging.getLogger('zros').warning(
                    'bridges with different namespaces answered; using "/": pass '
                    'bridge_namespace= to choose'
                )
        return BridgeScheme(namespace, send_type_hash)

    # --- time and logging ----------------------------------------------------------------

    @property
    def use_sim_time(self) -> bool:
        """Whether the node's clock follows ``/clock``."""
        return self.clock.sim

    def get_clock(self) -> Clock:
        """The node's clock (ROS time; sim time with ``use_sim_time``)."""
        return self.clock

    def now(self) -> Time:
        """The node's current ROS time."""
        return self.clock.now()

    def get_logger(self) -> Logger:
        """The node's logger (console, ``/rosout`` and Python's ``ros.<name>`` logger)."""
        return self._logger

    def _publish_rosout(self, entry: RosoutRecord) -> None:
        if not self._enable_rosout or self._closed:
            return
        try:
            with self._rosout_lock:
                if self._rosout is None:
                    from zros.pubsub import Publisher
                    from zros.qos import ROSOUT

                    self._rosout = Publisher('/rosout', 'rcl_interfaces/msg/Log', ROSOUT, node=self)
                    self._rosout_class = self._rosout.msg_type
            record = self._rosout_class(
                level=entry.level,
                name=entry.name,
                msg=entry.msg,
                file=entry.file,
                function=entry.function,
                line=entry.line,
            )
            record.stamp.sec, record.stamp.nanosec = divmod(entry.stamp, 1_000_000_000)
            self._rosout.write(record)
        except Exception:  # logging must never break the program that logs
            logging.getLogger('zros').debug('cannot publish on /rosout', exc_info=True)

    # --- parameters ----------------------------------------------------------------------

    def _refuse_sim_time_switch(self, changes: list[Any]) -> object:
        for change in changes:
            if change.name == 'use_sim_time' and change.value is not self.use_sim_time:
                return (
                    False,
                    'zros sets use_sim_time when a node starts (zros.Node(use_sim_time=...) '
                    'or -p use_sim_time:=true), not while it runs',
                )
        return True

    def declare_parameter(
        self,
        name: str,
        value: Any = None,
        descriptor: Descriptor | None = None,
        *,
        ignore_override: bool = False,
        **fields: Any,
    ) -> Any:
        """Declare a parameter and return its value (an override's, if one was given).

        ``fields`` are those of :class:`zros.params.Descriptor`: ``description``, ``read_only``,
        ``integer_range=(low, high, step)``, ``floating_point_range``, ``dynamic_typing``...
        """
        return self.parameters.declare(
            name, value, descriptor, ignore_override=ignore_override, **fields
        )

    def declare_parameters(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """Declare several parameters with their defaults; returns their values."""
        return {name: self.parameters.declare(name, value) for name, value in values.items()}

    def has_parameter(self, name: str) -> bool:
        """Whether the node has declared ``name``."""
        return self.parameters.has(name)

    def get_parameter(self, name: str) -> Any:
        """A parameter's value; ParameterNotDeclaredError for an unknown name."""
        return self.parameters.get(name)

    def set_parameter(self, name: str, value: Any) -> None:
        """Set a parameter; raises ParameterError with the reason when it is refused."""
        from zros.params import ParameterError

        result = self.parameters.set(name, value)
        if not result:
            raise ParameterError(result.reason)

    def set_parameters(self, values: Mapping[str, Any]) -> list[SetResult]:
        """Set parameters one by one; a result for each."""
        return self.parameters.set_many(values)

    def undeclare_parameter(self, name: str) -> None:
        """Remove a declared parameter (not a read-only one)."""
        self.parameters.undeclare(name)

    def add_on_set_parameters_callback(self, callback: Callable[[list[Any]], object]) -> None:
        """``callback(parameters)`` may refuse changes (return False, ``(False, reason)`` or a
        SetResult); it runs where the node spins when the change comes from the network."""
        self.parameters.add_on_set_callback(callback)

    def parameter_client(self, node_name: str, timeout: float = 5.0) -> ParameterClient:
        """The parameters of another node (``/robot/driver``)."""
        from zros.params import ParameterClient

        return ParameterClient(self, node_name, timeout)

    # --- the graph -------------------------------------------------------------------------

    @property
    def graph(self) -> Graph:
        """The live view of the ROS graph (shared by the nodes of a session)."""
        graph: Graph = self.transport.graph
        return graph

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        """Every topic on the network with its types, as rclpy lists them."""
        return list(self.graph.topics(self.scheme.namespace).items())

    def get_node_names(self) -> list[str]:
        """zros nodes by name, and each bridge's node (ROS nodes hide behind it)."""
        return self.graph.nodes()

    def count_publishers(self, topic: str) -> int:
        """How many publishers are announced on ``topic``."""
        return len(self.graph.publishers(self.scheme.key(self.resolve_name(topic))))

    def count_subscribers(self, topic: str) -> int:
        """How many subscribers are announced on ``topic``."""
        return len(self.graph.subscribers(self.scheme.key(self.resolve_name(topic))))

    def wait_for_publisher(self, topic: str, timeout: float | None = 5.0) -> bool:
        """Wait until a publisher on ``topic`` is announced (by a bridge or another node)."""
        key = self.scheme.key(self.resolve_name(topic))
        return self.graph.wait_until(lambda: self.graph.publishers(key), timeout)

    def wait_for_subscriber(self, topic: str, timeout: float | None = 5.0) -> bool:
        """Wait until a subscriber on ``topic`` is announced (by a bridge or another node)."""
        key = self.scheme.key(self.resolve_name(topic))
        return self.graph.wait_until(lambda: self.graph.subscribers(key), timeout)

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

    def create_service(
        self,
        srv_type: str | ServiceType,
        name: str,
        handler: Callable[..., Any] | None = None,
    ) -> Service:
        """A service server; ``handler(request)`` returns the response (see ``zros.Service``)."""
        from zros.services import Service

        return Service(name, srv_type, handler, node=self)

    def create_client(
        self, srv_type: str | ServiceType, name: str, timeout: float = 10.0
    ) -> Client:
        """A service client; ``client.call(request)`` returns the response."""
        from zros.services import Client

        return Client(name, srv_type, node=self, timeout=timeout)

    def create_action_server(
        self,
        action_type: str | ActionType,
        name: str,
        execute_callback: Callable[[ServerGoalHandle], Any],
        *,
        goal_callback: Callable[[Any], object] | None = None,
        cancel_callback: Callable[[ServerGoalHandle], object] | None = None,
        result_timeout: float = 900.0,
    ) -> ActionServer:
        """An action server; ``execute_callback(goal_handle)`` returns the result."""
        from zros.actions import ActionServer

        return ActionServer(
            name,
            action_type,
            execute_callback,
            goal_callback=goal_callback,
            cancel_callback=cancel_callback,
            node=self,
            result_timeout=result_timeout,
        )

    def create_action_client(self, action_type: str | ActionType, name: str) -> ActionClient:
        """An action client; ``client.send_goal(goal)`` returns a goal handle."""
        from zros.actions import ActionClient

        return ActionClient(name, action_type, node=self)

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
        return not (self._closed or interrupted())

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

    def spin_until_clock(self, deadline: int) -> None:
        """Run callbacks and timers until the node clock's timer base reaches ``deadline``."""
        while self.ok():
            remaining = self.clock.seconds_until(deadline)
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
        self._spin_loop = loop
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
            self._spin_loop = None
            self._executor._async_wakers.remove(waker)

    def run_coroutine(self, coroutine: Coroutine[Any, Any, T]) -> concurrent.futures.Future[T]:
        """Run an async callback: on the loop of :meth:`spin_async` while one spins the node,
        else on an event loop thread of the node's own (started on first use)."""
        loop = self._spin_loop
        if loop is None or not loop.is_running():
            with self._loop_lock:
                loop = self._own_loop
                if loop is None:
                    self._check_open()
                    loop = self._own_loop = asyncio.new_event_loop()
                    threading.Thread(
                        target=loop.run_forever,
                        name=f'zros async {self.fully_qualified_name}',
                        daemon=True,
                    ).start()
        return asyncio.run_coroutine_threadsafe(coroutine, loop)

    def _stop_own_loop(self) -> None:
        with self._loop_lock:
            loop, self._own_loop = self._own_loop, None
        if loop is None:
            return

        def stop() -> None:
            for task in asyncio.all_tasks(loop):
                task.cancel()
            loop.call_soon(loop.stop)

        with contextlib.suppress(RuntimeError):  # already closed
            loop.call_soon_threadsafe(stop)

    # --- lifetime --------------------------------------------------------------------------

    def destroy(self) -> None:
        """Undeclare every publisher, subscriber and timer of the node; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        if self._parameter_server is not None:
            self.parameters.on_change = None
        self._executor.stopped = True
        for entity in list(reversed(self._entities)):
            entity.close()
        self._entities.clear()
        for timer in list(self._executor._timers):
            timer.cancel()
        self._stop_own_loop()
        if self._clock_subscription is not None:
            self.clock.remove_listener(self._executor.wake)
            self._clock_subscription.close()
        self.transport.release_token(self._node_token)
        self.transport.remove_on_close(self.destroy)
        self._executor.wake()

    close = destroy

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()

    def __repr__(self) -> str:
        state = ' (destroyed)' if self._closed else ''
        return f'<zros Node {self.fully_qualified_name}{state}>'
