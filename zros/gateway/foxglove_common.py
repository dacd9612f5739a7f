"""What the live and the bag Foxglove servers share: starting the SDK's WebSocket server
safely, telling clients that fall behind, and the schemas of ROS types.

The Foxglove SDK (``foxglove-sdk`` on PyPI, the ``foxglove`` extra) owns the WebSocket side:
the protocol, a bounded outbox per client (``message_backlog_size`` messages; when it is full
the oldest data messages go), TLS. It does not tell a client that its messages were dropped;
it only logs ``outbox for client <address> full`` (at most every 30 s, for all its clients).
:class:`SlowClients` watches that log line and sends every client a warning status naming the
slow one (at most once per ``REPORT_PERIOD`` for one client: statuses go through the control
queue, which the SDK bounds too, and disconnects a client when it overflows).
"""

from __future__ import annotations

import logging
import os
import queue
import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from zros.errors import ZrosError
from zros.gateway.core import GatewayError
from zros.gateway.listen import Listen

if TYPE_CHECKING:
    from types import ModuleType

    import foxglove
    from foxglove.websocket import WebSocketServer

    from zros.cdr import TypeRegistry

_log = logging.getLogger('zros.gateway')

#: a keyword option of ``foxglove.start_server`` (listener, capabilities...), checked by the SDK
SdkOption = Any

#: foxglove_bridge's port
DEFAULT_PORT = 8765
#: messages each client's outbox holds before the oldest are dropped (the SDK's default)
DEFAULT_BACKLOG = 1024
#: seconds between two statuses about the same slow client
REPORT_PERIOD = 5.0
#: the SDK logger and line that say a client's outbox overflowed
_SDK_SEND_LOGGER = 'foxglove.websocket.connected_client.send_lossy'
_OUTBOX_FULL = re.compile(r'outbox for client (\S+) full')


def import_sdk() -> ModuleType:
    """The ``foxglove`` module of the SDK; GatewayError says how to install it."""
    try:
        import foxglove
    except ImportError:
        raise GatewayError(
            "the Foxglove SDK is not installed: pip install 'zros[foxglove]' (foxglove-sdk)"
        ) from None
    return foxglove


@dataclass(frozen=True)
class ServerOptions:
    """Where and how the WebSocket server listens.

    ``address`` defaults to loopback; any other address is reachable from the network and
    logs a warning. ``tls_cert`` and ``tls_key`` (PEM files, the key in PKCS#8 as
    ``zros tls init`` writes it) make it ``wss://``. ``message_backlog`` bounds each client's
    outbox (messages).
    """

    port: int = DEFAULT_PORT
    address: str = '127.0.0.1'
    tls_cert: str | os.PathLike[str] | None = None
    tls_key: str | os.PathLike[str] | None = None
    message_backlog: int = DEFAULT_BACKLOG
    name: str = 'zros'

    def _listen(self) -> Listen:
        return Listen(self.port, self.address, self.tls_cert, self.tls_key, 'the Foxglove server')

    @property
    def scheme(self) -> str:
        """``wss`` with TLS, else ``ws``."""
        return self._listen().scheme

    def check(self) -> None:
        """Refuse impossible settings; warn about an address reachable from the network."""
        self._listen().check()
        if self.message_backlog < 1:
            raise GatewayError(
                f'the message backlog must be at least 1, not {self.message_backlog}'
            )

    def start(self, **settings: SdkOption) -> WebSocketServer:
        """Start the SDK's server with these options and ``settings`` (capabilities, listener,
        context...); GatewayError when it cannot listen."""
        foxglove = import_sdk()
        self.check()
        cert, key = self._listen().tls_files()
        try:
            server: WebSocketServer = foxglove.start_server(
                name=self.name,
                host=self.address,
                port=self.port,
                message_backlog_size=self.message_backlog,
                tls_cert=cert,
                tls_key=key,
                **settings,
            )
        except RuntimeError as exc:  # the SDK's FoxgloveError: a port in use, no such host, bad TLS
            raise GatewayError(
                f'cannot start the Foxglove server on {self.address}:{self.port}: {exc}'
            ) from None
        return server

    def url(self, port: int) -> str:
        """The address clients open."""
        return self._listen().url(port)


class _OutboxLog(logging.Handler):
    def __init__(self, found: Callable[[str], None]) -> None:
        super().__init__(logging.INFO)
        self._found = found

    def emit(self, record: logging.LogRecord) -> None:
        match = _OUTBOX_FULL.search(record.getMessage())
        if match is not None:
            self._found(match.group(1))


class SlowClients:
    """Tells every client, with a warning status, when a client's outbox overflowed (its
    oldest messages are being dropped). Statuses are sent from a thread of its own, never from
    inside the SDK. ``overflows`` counts the overflows the SDK logged, ``reported`` the statuses
    sent."""

    def __init__(self, backlog: int) -> None:
        self._backlog = backlog
        self._server: WebSocketServer | None = None
        self._found: queue.SimpleQueue[str | None] = queue.SimpleQueue()
        self._last: dict[str, float] = {}  # client address -> when last reported
        self.overflows = 0
        self.reported = 0
        self._handler = _OutboxLog(self._found.put)
        logger = logging.getLogger(_SDK_SEND_LOGGER)
        if logger.getEffectiveLevel() > logging.INFO:
            logger.setLevel(logging.INFO)  # before the server starts: the SDK caches levels
        logger.addHandler(self._handler)
        self._thread = threading.Thread(target=self._run, name='zros foxglove status', daemon=True)

    def attach(self, server: WebSocketServer) -> None:
        """Start reporting to the clients of ``server``."""
        self._server = server
        self._thread.start()

    def _run(self) -> None:
        import foxglove

        while (address := self._found.get()) is not None:
            self.overflows += 1
            now = time.monotonic()
            if now - self._last.get(address, -REPORT_PERIOD) < REPORT_PERIOD:
                continue
            if len(self._last) > 1000:  # addresses of long gone clients
                self._last.clear()
            self._last[address] = now
            self.reported += 1
            message = (
                f'client {address} does not read fast enough: its oldest messages are being '
                f'dropped (each client has room for {self._backlog} messages)'
            )
            _log.warning(message)
            try:
                assert self._server is not None  # reporting starts once attached
                self._server.publish_status(
                    message, foxglove.StatusLevel.Warning, id=f'zros.slow.{address}'
                )
            except Exception:  # the server stopped meanwhile; this thread must keep draining
                _log.debug('could not send a status', exc_info=True)

    def close(self) -> None:
        """Stop reporting."""
        logging.getLogger(_SDK_SEND_LOGGER).removeHandler(self._handler)
        self._found.put(None)
        if self._thread.is_alive():
            self._thread.join(5.0)


def ros2msg_schema(registry: TypeRegistry, type_name: str) -> foxglove.Schema | None:
    """The Foxglove schema of a ROS type: the ``ros2msg`` text with its dependencies, as
    rosbag2 writes it into MCAP files; None when the registry does not know the type."""
    import foxglove

    from zros.cdr.render import render_bundle

    try:
        text = render_bundle(registry, type_name)
    except ZrosError as exc:
        _log.warning('no definition of %s: Foxglove gets no schema for it (%s)', type_name, exc)
        return None
    return foxglove.Schema(name=type_name, encoding='ros2msg', data=text.encode())
