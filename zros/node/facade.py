"""A zros node: a ROS name on the Zenoh network that owns publishers, subscribers and timers.

Zenoh delivers samples on its own threads; subscribers queue them as raw buffers and the node's
executor runs callbacks and timers on whichever thread calls :meth:`Node.spin_once` or
:meth:`Node.spin` (rosR's ``ros.SpinOnce``). Polling reads never need spinning.
"""

from __future__ import annotations

import concurrent.futures
import threading
from collections.abc import Coroutine, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, TypeVar

from zros.cdr import TypeRegistry, default_registry
from zros.closing import Closing
from zros.graph import graph_of
from zros.keyexpr.names import Remapping, expand
from zros.node.factories import EntityFactories
from zros.node.graph_methods import GraphMethods
from zros.node.parameter_methods import ParameterMethods
from zros.node.settings import NodeSettings, PathLike, check_keywords, node_transport
from zros.params import Parameter, ParameterStore, ParamValue
from zros.params.server import ParameterServer
from zros.pubsub.rosout import RosoutSink
from zros.runtime.clock import Clock, SimClock, Time
from zros.runtime.clock_feed import ClockSubscription
from zros.runtime.context import NodeContext
from zros.runtime.executor import Executor, shut_down_on_ctrl_c
from zros.runtime.logger import Logger, logger_name
from zros.runtime.timeouts import UNSET, Unset, either_timeout
from zros.services.typeinfo import NodeTypes
from zros.transport import Transport, TransportConfig
from zros.wire import KeyScheme, Wire, open_wire

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from zros.transport.config import SessionOptions

T = TypeVar('T')


class Node(EntityFactories, ParameterMethods, GraphMethods, Closing):
    """A ROS node on the Zenoh network.

    ``namespace`` is the node's own namespace (relative topic names resolve into it);
    ``bridge_namespace`` is the ``namespace`` setting of the zenoh-bridge-ros2dds to reach, which
    prefixes every Zenoh key; by default the namespace the bridges present report (``/`` when
    none answers at creation). ``args`` takes a command line with ``--ros-args`` (remappings
    ``-r from:=to``, ``__node``, ``__ns``, ``-p use_sim_time:=true``, ``--log-level``), applied on
    top of the command line of ``zros.init`` (rclpy's global arguments) unless
    ``use_global_arguments`` is false. Without ``transport``, the node uses the process's
    session, opened from ``connect``/``config``, the other settings of ``TransportConfig.create``
    (``mode``, ``tls``, ``user``, ``password``, ...) or the environment (see ``zros.transport``).

    ``use_sim_time`` (also ``ZROS_USE_SIM_TIME=1``) makes the node's clock, timers and rates
    follow ``/clock``. ``log_level`` (also ``ZROS_LOG_LEVEL``) is the threshold of its logger;
    ``enable_rosout`` publishes its log records on ``/rosout``.

    Parameters get their values, lowest priority first, from ``parameters``, the files of
    ``params_file`` and ``--params-file``, and ``-p name:=value``; with
    ``allow_undeclared_parameters`` those are declared at once and clients may set new names.
    ``start_parameter_services`` serves them to ROS tools.

    ``start_type_description_service`` (rclpy's name) serves ``~/get_type_description`` for the
    types of the node's entities, started when one first uses a type that is not standard
    (registered at run time, found in files), so that ``zros topic echo`` and ROS tools elsewhere
    learn it.

    ``wire`` picks the key scheme: ``'bridge'`` (zenoh-bridge-ros2dds, the default) or
    ``'rmw_zenoh'`` (ROS 2 nodes running rmw_zenoh, no bridge), also from ``ZROS_WIRE``; under
    rmw_zenoh ``domain_id`` (default ``ROS_DOMAIN_ID``, else 0) is the ROS domain. The node's
    ``wire`` attribute is then its :class:`~zros.wire.Wire`, whose ``name`` is that string.

    ``immediate_callbacks`` runs subscriber callbacks and service handlers as soon as a
    message or request arrives, on the thread that delivers it, instead of inside ``spin``:
    faster replies (one thread hand-over less), but callbacks of different subscriptions may
    run at the same time, and a callback that blocks holds up its subscription (and, once
    hundreds of messages wait, the session's deliveries). Timers still need ``spin``.
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
        parameters: Mapping[str, ParamValue] | None = None,
        params_file: PathLike | Sequence[PathLike] | None = None,
        allow_undeclared_parameters: bool = False,
        start_parameter_services: bool = True,
        start_type_description_service: bool = True,
        wire: str | None = None,
        domain_id: int | None = None,
        immediate_callbacks: bool = False,
        use_global_arguments: bool = True,
        **settings: Unpack[SessionOptions],
    ) -> None:
        check_keywords(settings)
        options = NodeSettings.parse(
            name, namespace, remap=remap, args=args, use_sim_time=use_sim_time,
            log_level=log_level, parameters=parameters, params_file=params_file, wire=wire,
            use_global_arguments=use_global_arguments,
        )  # fmt: skip
        self.name, self.namespace = options.name, options.namespace
        self.remapping: Remapping = options.remapping
        self.transport = node_transport(
            transport, connect=connect, config=config, wire=options.wire,
            wire_given=wire is not None, settings=settings,
        )  # fmt: skip
        self.registry: TypeRegistry = registry or default_registry()
        node_wire = open_wire(
            options.wire, self.transport, self.namespace, self.name, self.registry,
            settings={'bridge_namespace': bridge_namespace, 'domain_id': domain_id},
        )  # fmt: skip
        #: the node's wire: ``wire.name`` is the scheme's name (``str(wire)`` too)
        self.wire: Wire = node_wire
        self.scheme: KeyScheme = node_wire.scheme  #: the pure key functions of the wire
        # one clock for the node's life: use_sim_time switches it in place (timers keep it)
        self.clock: SimClock = SimClock(active=options.use_sim_time)
        #: what the node's entities get from it
        self.context = NodeContext(
            self.name, self.namespace, remapping=self.remapping, transport=self.transport,
            wire=node_wire, registry=self.registry, clock=self.clock,
            immediate_callbacks=immediate_callbacks,
        )  # fmt: skip
        if start_type_description_service:
            self.context.type_used = NodeTypes(self)
        sink = RosoutSink(self, options.log_level, enable_rosout)
        self._logger = Logger(logger_name(self.name, self.namespace), sink)
        self._clock_feed: ClockSubscription | None = None
        self._clock_lock = threading.Lock()  # parameter sets may come on several threads
        if options.use_sim_time:
            self._clock_feed = ClockSubscription(self, self.clock)
        self._node_token = node_wire.node_token
        self._warn_if_name_taken()
        self.transport.declare_token(self._node_token)
        self.transport.on_close(self.destroy)
        self.parameters = ParameterStore(
            self.fully_qualified_name, options.overrides, allow_undeclared_parameters
        )
        self._parameter_server: ParameterServer | None = None
        if start_parameter_services:
            self._parameter_server = ParameterServer(self, self.parameters)
        if not self.parameters.has('use_sim_time'):
            self.parameters.declare('use_sim_time', options.use_sim_time)
        self.parameters.add_on_set_callback(self._check_sim_time, internal=True)
        self.parameters.add_on_change(self._switch_sim_time)

    @staticmethod
    def _check_sim_time(changes: list[Parameter]) -> object:
        for change in changes:
            if change.name == 'use_sim_time' and not isinstance(change.value, bool):
                return (False, 'use_sim_time is true or false')
        return True

    def _switch_sim_time(
        self, new: list[Parameter], changed: list[Parameter], deleted: list[Parameter]
    ) -> None:
        """Follow ``/clock`` or leave it when ``use_sim_time`` changes, as ROS 2 nodes do."""
        for change in (*new, *changed):
            if change.name == 'use_sim_time' and change.value is not self.clock.sim:
                self._follow_clock(change.value is True)

    def _follow_clock(self, active: bool) -> None:
        """Switch the node's clock to ``/clock`` (True) or the system clock (False)."""
        with self._clock_lock:
            if active and self._clock_feed is None and not self.context.closed:
                self._clock_feed = ClockSubscription(self, self.clock)
            self.clock.switch(active)
            if not active and self._clock_feed is not None:
                self._clock_feed.close()
                self._clock_feed = None

    # --- names, time and logging -----------------------------------------------------------

    @property
    def fully_qualified_name(self) -> str:
        """``/namespace/name`` of this node."""
        return self.context.fully_qualified_name

    def get_name(self) -> str:
        """The node's name (rclpy's ``get_name``)."""
        return self.name

    def get_namespace(self) -> str:
        """The node's namespace, ``/`` at the root (rclpy's ``get_namespace``)."""
        return self.namespace

    def get_fully_qualified_name(self) -> str:
        """``/namespace/name`` (rclpy's ``get_fully_qualified_name``)."""
        return self.fully_qualified_name

    def resolve_name(self, name: str, kind: str = 'topic name') -> str:
        """The fully qualified form of a topic or service name, remappings applied."""
        return self.context.resolve_name(name, kind)

    def resolve_topic_name(self, topic: str, *, only_expand: bool = False) -> str:
        """rclpy's: the fully qualified topic name, remapped unless ``only_expand``."""
        if only_expand:
            return expand(topic, self.name, self.namespace)
        return self.context.resolve_name(topic)

    def resolve_service_name(self, service: str, *, only_expand: bool = False) -> str:
        """rclpy's: the fully qualified service name, remapped unless ``only_expand``."""
        if only_expand:
            return expand(service, self.name, self.namespace, 'service name')
        return self.context.resolve_name(service, 'service name')

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

    def _warn_if_name_taken(self) -> None:
        """Warn when the graph this session follows already shows a node of this name: as
        rcl, zros does not refuse it, and it asks nothing of the network (a graph not made yet,
        or one still filling, may not know the other node)."""
        graph = graph_of.peek(self.transport)
        if graph is not None and self.fully_qualified_name in graph.nodes():
            self._logger.warn(
                f'a node named {self.fully_qualified_name} is already on the network; both run, '
                'but whatever reaches a node by name (parameters, node info) may reach either'
            )

    def get_logger(self) -> Logger:
        """The node's logger (console, ``/rosout`` and Python's ``ros.<name>`` logger)."""
        return self._logger

    # --- spinning ------------------------------------------------------------------------

    def ok(self) -> bool:
        """True until the node is destroyed or the process got Ctrl-C."""
        return self.context.ok()

    @property
    def executor(self) -> Executor:
        """The executor that runs this node's callbacks (rclpy's ``node.executor``): a zros
        node has its own, from its creation on, and spins on whichever thread calls
        :meth:`spin`; ``node.executor = other`` raises ValueError."""
        return self.context.executor

    @executor.setter
    def executor(self, executor: Executor | None) -> None:
        if executor is not self.context.executor:
            raise ValueError(
                f'a zros node runs on its own executor: {self} cannot be added to another one '
                '(spin each node on a thread of its own, or use spin_async)'
            )

    # Ctrl-C without zros.init's handler raises KeyboardInterrupt where the spin waits: each spin
    # ends and shuts down as that handler does, so a `while node.ok()` loop ends as with it

    def spin_once(
        self, timeout: float | None = 0.0, *, timeout_sec: float | Unset | None = UNSET
    ) -> int:
        """Run due callbacks and timers, waiting up to ``timeout`` (or rclpy's ``timeout_sec``)
        seconds for one; returns how many ran. ``None`` waits until something runs. Ctrl-C ends
        it (0) and makes ``ok()`` false, with or without ``zros.init``."""
        wait = either_timeout(timeout, timeout_sec, 0.0)
        try:
            return self.context.executor.run_once(wait)
        except KeyboardInterrupt:
            shut_down_on_ctrl_c()
            return 0

    def spin(self, timeout: float | None = None) -> None:
        """Run callbacks and timers until the node stops being ok (or ``timeout`` seconds); Ctrl-C
        ends it and makes ``ok()`` false, with or without ``zros.init``."""
        try:
            self.context.executor.spin(timeout)
        except KeyboardInterrupt:
            shut_down_on_ctrl_c()

    def spin_until_future_complete(
        self,
        future: concurrent.futures.Future[T],
        timeout: float | Unset | None = UNSET,
        *,
        timeout_sec: float | Unset | None = UNSET,
    ) -> None:
        """Run callbacks and timers until ``future`` (of ``call_async``, ``send_goal_async``...)
        is done or ``timeout`` (or rclpy's ``timeout_sec``) seconds pass (None or negative: no
        limit), as rclpy's ``spin_until_future_complete``; Ctrl-C ends it as :meth:`spin`."""
        wait = either_timeout(timeout, timeout_sec, None)
        try:
            self.context.executor.spin_until_future_complete(future, wait)
        except KeyboardInterrupt:
            shut_down_on_ctrl_c()

    def spin_until_clock(self, deadline: int) -> None:
        """Run callbacks and timers until the node clock's timer base reaches ``deadline`` (or
        Ctrl-C, as :meth:`spin`)."""
        try:
            self.context.executor.spin_until_clock(self.clock, deadline)
        except KeyboardInterrupt:
            shut_down_on_ctrl_c()

    def spin_until(self, deadline: float) -> None:
        """Run callbacks and timers until ``time.monotonic()`` reaches ``deadline`` (or Ctrl-C,
        as :meth:`spin`)."""
        try:
            self.context.executor.spin_until(deadline)
        except KeyboardInterrupt:
            shut_down_on_ctrl_c()

    async def spin_async(self) -> None:
        """Run callbacks and timers on the asyncio loop until the node stops being ok."""
        await self.context.executor.spin_async()

    def run_coroutine(self, coroutine: Coroutine[object, None, T]) -> concurrent.futures.Future[T]:
        """Run an async callback: on the loop of :meth:`spin_async` while one spins the node,
        else on an event loop thread of the node's own (started on first use)."""
        return self.context.executor.run_coroutine(coroutine)

    # --- lifetime --------------------------------------------------------------------------

    def destroy(self) -> None:
        """Undeclare every publisher, subscriber and timer of the node; safe to call twice."""
        if self.context.closed:
            return
        if self._parameter_server is not None:
            self.parameters.on_change = None
        self.context.close()
        self.transport.release_token(self._node_token)
        self.transport.remove_on_close(self.destroy)

    #: ``close()`` as every other zros object (and ``with``) spells it
    close = destroy
    #: rclpy's name
    destroy_node = destroy

    def __repr__(self) -> str:
        state = ' (destroyed)' if self.context.closed else ''
        return f'<zros Node {self.fully_qualified_name}{state}>'
