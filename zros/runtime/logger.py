"""ROS logging: console lines in ROS 2's format, ``/rosout`` records, Python ``logging`` both ways.

Every node has a logger named after it (``node.get_logger()``, ``zros.info(...)`` for the
default node). A record below the level threshold is dropped; otherwise it is

* published as ``rcl_interfaces/msg/Log`` on ``/rosout`` (reliable, transient local, depth 1000),
  with the caller's file, function and line, as rclpy does;
* handed to the Python logger ``ros.<logger name>``, whose default handler prints
  ``[INFO] [1740933158.226629828] [talker]: text`` to stderr. Attach handlers to ``ros`` to route
  records elsewhere; :class:`RosoutHandler` routes records of other Python loggers to ``/rosout``.

The threshold comes from ``level=``, ``--ros-args --log-level LEVEL``, or ``ZROS_LOG_LEVEL``.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import time
from typing import TYPE_CHECKING, NamedTuple, Protocol, TypedDict

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from zros.runtime.clock import Clock

DEBUG, INFO, WARN, ERROR, FATAL = 10, 20, 30, 40, 50
LEVELS = {'debug': DEBUG, 'info': INFO, 'warn': WARN, 'warning': WARN, 'error': ERROR,
          'fatal': FATAL, 'critical': FATAL}  # fmt: skip
_NAMES = {DEBUG: 'DEBUG', INFO: 'INFO', WARN: 'WARN', ERROR: 'ERROR', FATAL: 'FATAL'}

#: the Python logger every ROS record goes through
PY_LOGGER = 'ros'


class LogOptions(TypedDict, total=False):
    """What limits the repeats of a log call (see :meth:`Logger.log`)."""

    once: bool
    throttle: float | None
    skip_first: bool
    throttle_duration_sec: float | None
    throttle_time_source_type: Clock | None


class _CallSite:
    """What the filters of one log call site remember (rclpy keeps one such context per site)."""

    __slots__ = ('last', 'logged', 'skipped')

    def __init__(self) -> None:
        self.last: int | None = None  #: nanoseconds of the last record throttle let through
        self.skipped = False
        self.logged = False

    def passes(
        self, once: bool, throttle: float | None, skip_first: bool, clock: Clock | None
    ) -> bool:
        """Whether this call logs; each filter in rclpy's order (throttle, skip_first, once)
        counts the call only when the filters before it let it through, as rclpy's do."""
        if throttle is not None:
            now = time.monotonic_ns() if clock is None else clock.now().nanoseconds
            if self.last is not None and now < self.last + throttle * 1e9:
                return False
            self.last = now
        if skip_first and not self.skipped:
            self.skipped = True
            return False
        if once:
            if self.logged:
                return False
            self.logged = True
        return True


class RosoutRecord(NamedTuple):
    """The fields of one ``rcl_interfaces/msg/Log`` record."""

    stamp: int  #: nanoseconds of the node's clock
    level: int
    name: str
    msg: str
    file: str
    function: str
    line: int


class LogSink(Protocol):
    """Where a node's loggers send records besides the console (its ``/rosout``), and the
    node's threshold and clock."""

    @property
    def level(self) -> int:
        """The node's threshold (``log_level=``, ``--log-level``, ``ZROS_LOG_LEVEL``)."""

    def stamp(self) -> int:
        """Nanoseconds of the node's clock now."""

    def publish(self, record: RosoutRecord) -> None:
        """Send one record (on ``/rosout``); never raises."""


class HasLogger(Protocol):
    """A node, as :class:`RosoutHandler` sees it."""

    def get_logger(self) -> Logger:
        """The node's logger."""


def parse_level(level: str | int | None) -> int:
    """A ROS severity from a name (``'debug'``, ``'WARN'``...) or a number."""
    if level is None:
        return INFO
    if isinstance(level, int):
        return level
    try:
        return LEVELS[level.strip().lower()]
    except KeyError:
        raise ValueError(
            f'unknown log level {level!r}; levels are debug, info, warn, error, fatal'
        ) from None


def level_from_environment() -> int | None:
    """The level in ``ZROS_LOG_LEVEL``, or None when unset."""
    value = os.environ.get('ZROS_LOG_LEVEL')
    return parse_level(value) if value else None


def level_from_args(argv: list[str] | tuple[str, ...] | None) -> int | None:
    """The ``--log-level LEVEL`` of a ``--ros-args`` section (``name:=LEVEL`` forms ignored)."""
    if not argv or '--ros-args' not in argv:
        return None
    args = list(argv)
    for index, arg in enumerate(args):
        if arg == '--log-level' and index + 1 < len(args) and ':=' not in args[index + 1]:
            return parse_level(args[index + 1])
        if arg.startswith('--log-level=') and ':=' not in arg:
            return parse_level(arg.split('=', 1)[1])
    return None


class RosFormatter(logging.Formatter):
    """``[SEVERITY] [seconds.nanoseconds] [logger]: message``, as ROS 2 prints by default."""

    def format(self, record: logging.LogRecord) -> str:
        """The ROS 2 console line of a record: ``[LEVEL] [stamp] [name]: text``."""
        stamp = getattr(record, 'ros_stamp', None)
        if stamp is None:
            stamp = int(record.created * 1e9)
        severity = _NAMES.get(record.levelno, logging.getLevelName(record.levelno))
        name = getattr(record, 'ros_name', record.name)
        text = f'[{severity}] [{stamp // 1_000_000_000}.{stamp % 1_000_000_000:09d}] [{name}]: '
        text += record.getMessage()
        if record.exc_info:
            text += '\n' + self.formatException(record.exc_info)
        return text


_console_lock = threading.Lock()
_console_handler: logging.Handler | None = None


def _console() -> logging.Logger:
    """The ``ros`` Python logger, with the ROS console handler installed once."""
    global _console_handler  # noqa: PLW0603
    logger = logging.getLogger(PY_LOGGER)
    with _console_lock:
        if _console_handler is None:
            use_stdout = os.environ.get('RCUTILS_LOGGING_USE_STDOUT', '') == '1'
            handler = logging.StreamHandler(sys.stdout if use_stdout else sys.stderr)
            handler.setFormatter(RosFormatter())
            logger.addHandler(handler)
            logger.propagate = False
            logger.setLevel(logging.DEBUG)  # each zros Logger applies its own threshold
            _console_handler = handler
    return logger


def logger_name(node_name: str, namespace: str) -> str:
    """The logger name ROS 2 gives a node: its namespace and name joined by dots."""
    parts = [part for part in namespace.split('/') if part] + [node_name]
    return '.'.join(parts)


class Logger:
    """A named ROS logger; with a node's ``sink``, its records also go to ``/rosout``."""

    def __init__(self, name: str, sink: LogSink | None = None, level: int | None = None) -> None:
        self.name = name
        self.sink = sink  #: the node's /rosout, threshold and clock (None: console only)
        self._level = level
        self._py = _console().getChild(name)
        self._sites: dict[tuple[str, int, int], _CallSite] = {}

    @property
    def level(self) -> int:
        """The threshold: records below it are dropped."""
        if self._level is not None:
            return self._level
        if self.sink is not None:
            return self.sink.level
        return level_from_environment() or INFO

    def get_effective_level(self) -> int:
        """The threshold in force (rclpy's name for :attr:`level`)."""
        return self.level

    def set_level(self, level: str | int) -> None:
        """Set the threshold: ``'debug'``...``'fatal'`` or a number."""
        self._level = parse_level(level)

    def get_child(self, suffix: str) -> Logger:
        """A logger named ``<name>.<suffix>`` with the same node and threshold."""
        return Logger(f'{self.name}.{suffix}', self.sink, self._level)

    def is_enabled_for(self, level: int) -> bool:
        """Whether a record at ``level`` would be logged."""
        return level >= self.level

    def log(
        self,
        message: object,
        level: str | int = INFO,
        *,
        once: bool = False,
        throttle: float | None = None,
        skip_first: bool = False,
        throttle_duration_sec: float | None = None,
        throttle_time_source_type: Clock | None = None,
        stacklevel: int = 1,
    ) -> bool:
        """Log ``message`` at ``level``; returns whether it was emitted.

        Per call site, as rclpy's logger: ``once``, only the first time; ``throttle`` (rclpy's
        ``throttle_duration_sec``), at most once per that many seconds of the monotonic clock
        (of ``throttle_time_source_type``, a clock such as ``node.get_clock()``, when given);
        ``skip_first``, not the first time.
        """
        if throttle_duration_sec is not None:
            if throttle is not None:
                raise TypeError("give throttle= or rclpy's throttle_duration_sec=, not both")
            throttle = throttle_duration_sec or None  # rclpy: 0 throttles nothing
        severity = parse_level(level)
        if severity < self.level:
            return False
        frame = sys._getframe(stacklevel)
        if once or throttle is not None or skip_first:
            # f_lasti tells apart two calls on one line, as rclpy's call sites do
            site = (frame.f_code.co_filename, frame.f_lineno, frame.f_lasti)
            state = self._sites.get(site)
            if state is None:
                state = self._sites[site] = _CallSite()
            if not state.passes(once, throttle, skip_first, throttle_time_source_type):
                return False
        self._emit(severity, str(message), frame.f_code.co_filename, frame.f_code.co_name,
                   frame.f_lineno)  # fmt: skip
        return True

    def _emit(self, severity: int, text: str, file: str, function: str, line: int) -> None:
        sink = self.sink
        stamp = sink.stamp() if sink is not None else time.time_ns()
        if sink is not None:
            sink.publish(RosoutRecord(stamp, severity, self.name, text, file, function, line))
        record = logging.LogRecord(self._py.name, severity, file, line, text, None, None, function)
        record.ros_stamp = stamp
        record.ros_name = self.name
        record.ros_published = sink is not None
        self._py.handle(record)

    def debug(self, message: object, **options: Unpack[LogOptions]) -> bool:
        """Log at DEBUG; see :meth:`log` for ``once``, ``throttle``, ``skip_first``."""
        return self.log(message, DEBUG, stacklevel=2, **options)

    def info(self, message: object, **options: Unpack[LogOptions]) -> bool:
        """Log at INFO; see :meth:`log` for ``once``, ``throttle``, ``skip_first``."""
        return self.log(message, INFO, stacklevel=2, **options)

    def warn(self, message: object, **options: Unpack[LogOptions]) -> bool:
        """Log at WARN; see :meth:`log` for ``once``, ``throttle``, ``skip_first``."""
        return self.log(message, WARN, stacklevel=2, **options)

    #: Python logging's name (``warn`` is ROS's)
    warning = warn

    def error(self, message: object, **options: Unpack[LogOptions]) -> bool:
        """Log at ERROR; see :meth:`log` for ``once``, ``throttle``, ``skip_first``."""
        return self.log(message, ERROR, stacklevel=2, **options)

    def fatal(self, message: object, **options: Unpack[LogOptions]) -> bool:
        """Log at FATAL; see :meth:`log` for ``once``, ``throttle``, ``skip_first``."""
        return self.log(message, FATAL, stacklevel=2, **options)

    def __repr__(self) -> str:
        return f'<zros Logger {self.name} ({_NAMES.get(self.level, self.level)})>'


class RosoutHandler(logging.Handler):
    """A ``logging`` handler that publishes records of Python loggers on a node's ``/rosout``.

    ``logging.getLogger().addHandler(RosoutHandler(node))`` sends a library's logs where ROS
    tools (rqt_console, Foxglove) show them. Records zros published already are skipped.
    """

    def __init__(self, node: HasLogger, level: int = logging.NOTSET) -> None:
        super().__init__(level)
        self.node = node

    def emit(self, record: logging.LogRecord) -> None:
        """Publish a Python logging record on the node's ``/rosout``."""
        sink = self.node.get_logger().sink
        if getattr(record, 'ros_published', False) or sink is None:
            return
        try:
            sink.publish(
                RosoutRecord(
                    int(record.created * 1e9),
                    min(max(record.levelno, DEBUG), FATAL),
                    record.name,
                    record.getMessage(),
                    record.pathname,
                    record.funcName,
                    record.lineno,
                )
            )
        except Exception:  # a handler never raises: logging's handleError reports it
            self.handleError(record)
