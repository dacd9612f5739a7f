"""The rosR-shaped module API: one default node per process.

Each function is a rosR name (``ros.Init`` -> ``zros.init``) over the default node; a
:class:`zros.Node` is the object way, with the same calls as its methods (several nodes, rclpy's
names). The module-level classes (``zros.Subscriber``, ``zros.Timer``...) take ``node=`` and
use the default node without it.

zros.init('R_demo')            # ros.Init
while zros.ok():               # ros.OK (Ctrl-C makes it false)
    zros.spin_once(0.1)        # ros.SpinOnce
"""

from __future__ import annotations

import concurrent.futures
import enum
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from types import FrameType
from typing import TYPE_CHECKING, TypeVar, overload

from zros.errors import ZrosError
from zros.node import Node
from zros.node.settings import set_global_arguments
from zros.params import (
    ParameterClient,
    ParameterError,
    ParameterNotDeclaredError,
    ParameterType,
    ParamValue,
)
from zros.runtime.clock import Time
from zros.runtime.defaults import (
    NotInitializedError,
    set_default_node,
    set_default_node_factory,
)
from zros.runtime.executor import Executor, wake_all
from zros.runtime.logger import DEBUG, ERROR, FATAL, INFO, WARN, Logger, LogOptions
from zros.runtime.signal import (
    clear_interrupt,
    interrupt,
    interrupted,
    main_thread_raises,
    start_listener_thread,
)
from zros.runtime.timeouts import UNSET, Unset, either_timeout
from zros.transport import TransportConfig, close_default_transport, default_transport
from zros.wire import session_config

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from zros.node.settings import NodeKeywords, NodeOptions

T = TypeVar('T')
_default: Node | None = None
#: makes the default node after ``zros.init()`` without a name, when first needed
_pending: Callable[[str], Node] | None = None
_previous_handler: signal.Handlers | int | Callable[[int, FrameType | None], object] | None = None
_lock = threading.Lock()


def _on_sigint(signum: int, frame: FrameType | None) -> None:
    if interrupted():  # a second Ctrl-C stops the program the usual way
        signal.signal(signal.SIGINT, signal.default_int_handler)
        raise KeyboardInterrupt
    interrupt()
    wake_all()
    if main_thread_raises():  # inside a service call waiting in Zenoh's code
        raise KeyboardInterrupt


@overload
def init(
    name: str,
    namespace: str = '/',
    *,
    connect: str | Sequence[str] | None = None,
    config: TransportConfig | None = None,
    args: Sequence[str] | None = None,
    bridge_namespace: str | None = None,
    handle_sigint: bool = True,
    **options: Unpack[NodeOptions],
) -> Node: ...


@overload
def init(
    name: None = None,
    namespace: str = '/',
    *,
    connect: str | Sequence[str] | None = None,
    config: TransportConfig | None = None,
    args: Sequence[str] | None = None,
    bridge_namespace: str | None = None,
    handle_sigint: bool = True,
    **options: Unpack[NodeOptions],
) -> None: ...


def init(
    name: str | None = None,
    namespace: str = '/',
    *,
    connect: str | Sequence[str] | None = None,
    config: TransportConfig | None = None,
    args: Sequence[str] | None = None,
    bridge_namespace: str | None = None,
    handle_sigint: bool = True,
    **options: Unpack[NodeOptions],
) -> Node | None:
    """Create the default node (rosR: ``ros.Init``) and return it.

    Without ``name`` (rclpy's ``rclpy.init(args=args)``) no node is made now: the default node,
    named ``zros``, appears when a module function or class first needs it, so a program of
    ``zros.Node`` objects shows only its own nodes in the graph. With ``handle_sigint`` (the
    default, main thread only) the first Ctrl-C makes ``ok()`` false so a ``while zros.ok()``
    loop ends cleanly; a second one raises KeyboardInterrupt.

    The ``--ros-args`` of ``args`` (``sys.argv`` when None, as rclpy reads it) apply to every
    node made until ``shutdown()``, a node's own ``args=`` on top; arguments outside
    ``--ros-args`` are the program's and ignored. A malformed one raises here.
    """
    global _default, _pending, _previous_handler  # noqa: PLW0603
    with _lock:
        if (_default is not None and _default.ok()) or (_pending is not None and ok()):
            where = f' (node {_default.fully_qualified_name})' if _default is not None else ''
            raise ZrosError(
                f'zros.init was already called{where}; '
                'call zros.shutdown() first, or create more nodes with zros.Node(...)'
            )
        set_global_arguments(sys.argv if args is None else args)
        clear_interrupt()
        if name is None and (connect is not None or config is not None):
            # open the process's session now: the user's own Nodes use it too
            config = config or session_config(connect)
            default_transport(config)
            connect = None
        keywords: NodeKeywords = {
            'connect': connect, 'config': config, 'args': None,  # init's are the global ones
            'bridge_namespace': bridge_namespace, **options,
        }  # fmt: skip

        def make(node_name: str) -> Node:
            return Node(node_name, namespace, **keywords)

        try:
            made = make(name) if name is not None else None  # a failure leaves nothing behind
        except BaseException:
            set_global_arguments(None)
            raise
        _pending = make
        set_default_node_factory(default_node)
        if made is not None:
            _default = made
            set_default_node(_default)
        if handle_sigint and threading.current_thread() is threading.main_thread():
            start_listener_thread()
            previous = signal.signal(signal.SIGINT, _on_sigint)
            if previous is not _on_sigint:
                _previous_handler = previous
        return _default


def create_node(
    node_name: str, *, namespace: str | None = None, **options: Unpack[NodeKeywords]
) -> Node:
    """A new node (rclpy's ``rclpy.create_node``): ``zros.Node(node_name, namespace or '/',
    **options)``, with ``Node``'s keywords; rclpy's ``context=`` has no zros counterpart and,
    as any keyword ``Node`` does not take, raises TypeError."""
    return Node(node_name, namespace or '/', **options)


def default_node() -> Node:
    """The node ``zros.init`` created (or, after ``zros.init()`` without a name, creates now),
    which the module functions and classes use."""
    global _default  # noqa: PLW0603
    with _lock:
        if _default is None and _pending is not None:
            _default = _pending('zros')
            set_default_node(_default)
    if _default is None:
        raise NotInitializedError(
            'no default node: call zros.init("my_node") first, or pass node= explicitly'
        )
    return _default


def ok() -> bool:
    """False after ``shutdown()``, after Ctrl-C, or before ``init`` (rosR: ``ros.OK``)."""
    if _default is not None:
        return _default.ok()
    return _pending is not None and not interrupted()


def spin_once(
    node: Node | float | Unset | None = UNSET,
    timeout: float | Unset | None = UNSET,
    *,
    timeout_sec: float | Unset | None = UNSET,
) -> int:
    """Run the default node's due callbacks and timers (rosR: ``ros.SpinOnce``).

    Waits up to ``timeout`` seconds (default 0) for something to run; returns how many ran.
    ``zros.spin_once(node, timeout_sec=t)`` is rclpy's: that node's, and without a timeout it
    waits until something runs, as rclpy's does.
    """
    target: Node | None = None
    if isinstance(node, Node):
        target = node
    elif node is not UNSET:  # zros.spin_once(0.1) (or None): the timeout
        if timeout is not UNSET:
            raise TypeError('zros.spin_once takes (node, timeout) or (timeout), not two timeouts')
        timeout = node
    wait = either_timeout(timeout, timeout_sec, 0.0 if target is None else None)
    return (default_node() if target is None else target).spin_once(wait)


def spin(node: Node | float | None = None, timeout: float | None = None) -> None:
    """Run a node's callbacks until it stops being ok or Ctrl-C (or ``timeout`` seconds):
    ``node``'s as rclpy's ``rclpy.spin(node)``, else the default node's (``zros.spin(0.5)``
    reads as a timeout); rosR had only ``ros.SpinOnce``."""
    if node is None or isinstance(node, (int, float)):
        timeout = node if timeout is None else timeout
        node = default_node()
    node.spin(timeout)


def spin_until_future_complete(
    node: Node,
    future: concurrent.futures.Future[T],
    executor: Executor | None = None,
    timeout_sec: float | Unset | None = UNSET,
    *,
    timeout: float | Unset | None = UNSET,
) -> None:
    """Spin ``node`` until ``future`` is done or ``timeout_sec`` (or ``timeout``) seconds pass
    (None or negative: no limit), as rclpy's. Each zros node has its executor: ``executor`` may
    only be that one (``node.context.executor``); another raises ValueError, as it would not
    run ``node``."""
    if executor is not None and executor is not node.context.executor:
        raise ValueError(
            f'a zros node runs on its own executor: pass executor=None (or '
            f'node.context.executor), not the executor of {executor.name!r}, to spin {node}'
        )
    node.spin_until_future_complete(future, timeout, timeout_sec=timeout_sec)


def shutdown() -> None:
    """Destroy the default node, close the process's Zenoh session, restore Ctrl-C (rclpy:
    ``rclpy.shutdown``)."""
    global _default, _pending, _previous_handler  # noqa: PLW0603
    with _lock:
        _pending = None
        set_global_arguments(None)
        set_default_node_factory(None)
        _clients.clear()  # parameter clients of the default node
        if _default is not None:
            _default.destroy()
            _default = None
            set_default_node(None)
        close_default_transport()
        if _previous_handler is not None and threading.current_thread() is threading.main_thread():
            if signal.getsignal(signal.SIGINT) is _on_sigint:
                signal.signal(signal.SIGINT, _previous_handler)
            _previous_handler = None


# --- logging and time on the default node (rosR: ros.Info, ros.Logging, ros.TimeNow) ----------


def get_logger() -> Logger:
    """The default node's logger; before ``zros.init`` a console-only logger named ``zros``."""
    global _console_logger  # noqa: PLW0603
    if _default is not None:
        return _default.get_logger()
    if _console_logger is None:
        _console_logger = Logger('zros')
    return _console_logger


_console_logger: Logger | None = None


def log(message: object, level: str | int = 'info', **options: Unpack[LogOptions]) -> bool:
    """Log ``message`` at ``level`` (``'debug'``...``'fatal'``) on the default node (rosR:
    ``ros.Logging``)."""
    return get_logger().log(message, level, stacklevel=2, **options)


def debug(message: object, **options: Unpack[LogOptions]) -> bool:
    """Log at DEBUG on the default node (rosR: ``ros.Debug``); ``once=True``,
    ``throttle=seconds`` limit repeats."""
    return get_logger().log(message, DEBUG, stacklevel=2, **options)


def info(message: object, **options: Unpack[LogOptions]) -> bool:
    """Log at INFO on the default node (rosR: ``ros.Info``): console, ``/rosout``, logging."""
    return get_logger().log(message, INFO, stacklevel=2, **options)


def warn(message: object, **options: Unpack[LogOptions]) -> bool:
    """Log at WARN on the default node (rosR: ``ros.Warn``)."""
    return get_logger().log(message, WARN, stacklevel=2, **options)


def error(message: object, **options: Unpack[LogOptions]) -> bool:
    """Log at ERROR on the default node (rosR: ``ros.Error``)."""
    return get_logger().log(message, ERROR, stacklevel=2, **options)


def fatal(message: object, **options: Unpack[LogOptions]) -> bool:
    """Log at FATAL on the default node (rosR: ``ros.Fatal``)."""
    return get_logger().log(message, FATAL, stacklevel=2, **options)


def time_now() -> Time:
    """The default node's ROS time (rosR: ``ros.TimeNow``; sim time with ``use_sim_time``);
    wall time before init."""
    if _default is not None:
        return _default.now()
    return Time(time.time_ns())


# --- parameters (rosR: ros.ParamSet/Get/Type/Delete) ----------------------------------------


class _Missing(enum.Enum):
    MISSING = enum.auto()


_MISSING = _Missing.MISSING
_clients: dict[tuple[int, str], ParameterClient] = {}


def _target(name: str, node: str | None) -> tuple[str | None, str]:
    """``'/driver:speed'`` -> (``'/driver'``, ``'speed'``); a bare name is the default node's."""
    if node is None and ':' in name:
        node, _, name = name.rpartition(':')
    if node is not None and not node.startswith('/'):
        node = '/' + node
    own = default_node().fully_qualified_name
    return (None if node in (None, own) else node), name


def _remote(node_name: str, timeout: float) -> ParameterClient:
    owner = default_node()
    key = (id(owner), node_name)
    client = _clients.get(key)
    if client is None or client.node is not owner:
        client = _clients[key] = owner.parameter_client(node_name, timeout)
    return client


def param_set(
    name: str, value: ParamValue, *, node: str | None = None, timeout: float = 5.0
) -> None:
    """Set a parameter (rosR: ``ros.ParamSet``): of the default node, declaring it if new, or of
    another node with ``'/other_node:name'`` or ``node='/other_node'``. Raises ParameterError
    with the reason when refused."""
    target, parameter = _target(name, node)
    if target is not None:
        _remote(target, timeout).set(parameter, value, timeout)
        return
    own = default_node()
    if not own.has_parameter(parameter):
        own.declare_parameter(parameter, value, dynamic_typing=True, ignore_override=True)
        return
    result = own.parameters.set(parameter, value)
    if not result:
        raise ParameterError(result.reason)


def param_get(
    name: str,
    default: ParamValue | _Missing = _MISSING,
    *,
    node: str | None = None,
    timeout: float = 5.0,
) -> ParamValue:
    """A parameter's value (rosR: ``ros.ParamGet``); ``default`` when it is not set, else
    ParameterNotDeclaredError."""
    target, parameter = _target(name, node)
    if target is not None:
        value = _remote(target, timeout).get(parameter, timeout)
        found = value is not None
    else:
        own = default_node()
        found = own.has_parameter(parameter)
        value = own.parameters.get(parameter) if found else None
    if found:
        return value
    if not isinstance(default, _Missing):
        return default
    where = target or default_node().fully_qualified_name
    raise ParameterNotDeclaredError(f"node {where} has no parameter '{parameter}'")


def param_type(name: str, *, node: str | None = None, timeout: float = 5.0) -> str | None:
    """The ROS 2 type name of a parameter (``'integer'``, ``'double_array'``...), or None when
    it is not set (rosR: ``ros.ParamType``, which gave NULL)."""
    target, parameter = _target(name, node)
    if target is not None:
        kind = _remote(target, timeout).get_parameter_types([parameter], timeout)[parameter]
    else:
        kind = default_node().parameters.type_of(parameter)
    return None if kind is ParameterType.NOT_SET else kind.ros_name


def param_delete(name: str, *, node: str | None = None, timeout: float = 5.0) -> None:
    """Remove a parameter (rosR: ``ros.ParamDelete``); another node's only if it allows it."""
    target, parameter = _target(name, node)
    if target is not None:
        _remote(target, timeout).set(parameter, None, timeout)
        return
    default_node().undeclare_parameter(parameter)
