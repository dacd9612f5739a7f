"""What the live and the bag Foxglove servers share: starting the SDK's WebSocket server
behind the front that guards it, and the schemas of ROS types.

The Foxglove SDK (``foxglove-sdk`` on PyPI, the ``foxglove`` extra) owns the protocol; it
listens on a private loopback address, plain. Clients reach it through
:class:`~zros.gateway.foxglove.front.Front` on the public address, which checks their
``Origin``, accepts both names of the protocol, terminates TLS and bounds each client's queue
in bytes; the front runs in a process of its own
(:class:`~zros.gateway.foxglove.front_process.FrontProcess`). The SDK's own outbox
(``message_backlog_size`` messages) lies between the two and stays short: the front always
reads it.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict, cast

from zros.errors import ZrosError
from zros.gateway.common.admission import check_max_clients
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.limits import CLIENT_BUFFER, FOXGLOVE_PORT, MAX_CLIENTS
from zros.gateway.common.listen import Listen
from zros.gateway.common.origins import FOXGLOVE_APP
from zros.gateway.foxglove.front import private_loopback
from zros.gateway.foxglove.front_process import FrontProcess
from zros.gateway.foxglove.sdk_logs import bound_sdk_logs
from zros.version import install_hint

if TYPE_CHECKING:
    from types import ModuleType

    import foxglove
    from foxglove import AssetHandler, Context
    from foxglove.websocket import Capability, ServerListener, WebSocketServer
    from typing_extensions import Unpack

    from zros.cdr import TypeRegistry

_log = logging.getLogger('zros.gateway')


class SdkOptions(TypedDict, total=False):
    """The keyword options of ``foxglove.start_server`` a zros server chooses."""

    capabilities: list[Capability] | None
    #: an object with some of ``foxglove.websocket.ServerListener``'s methods: the SDK calls
    #: those it has (the Protocol's defaults are no-ops)
    server_listener: object
    supported_encodings: list[str] | None
    asset_handler: AssetHandler | None
    context: Context | None
    playback_time_range: tuple[int, int] | None


#: messages the SDK queues for each client before dropping the oldest. The front reads them at
#: once; they wait only when its thread is starved of CPU and the loopback socket between them
#: is full (its megabytes absorb bursts of small messages): then they are camera images, and
#: the SDK's own default (1,024) was gigabytes. Its control messages share the bound: a
#: client whose control queue overflows is disconnected by the SDK.
DEFAULT_BACKLOG = 32


def import_sdk() -> ModuleType:
    """The ``foxglove`` module of the SDK; GatewayError says how to install it."""
    try:
        import foxglove  # noqa: PLC0415 (optional: the foxglove extra)
    except ImportError:
        raise GatewayError(
            f'the Foxglove SDK (foxglove-sdk) is not installed: {install_hint("foxglove")}'
        ) from None
    return foxglove


@dataclass(frozen=True)
class ServerOptions:
    """Where and how the WebSocket server listens.

    ``address`` defaults to loopback; any other address is reachable from the network and
    logs a warning. ``tls_cert`` and ``tls_key`` (PEM files, the key in PKCS#8 as
    ``zros tls init`` writes it) make it ``wss://``. ``message_backlog`` bounds the SDK's
    outbox of each client (messages), ``client_buffer`` the front's queue of each (bytes);
    ``max_clients`` connections are served at once.
    Browsers are accepted from pages of this machine and of ``allow_origins`` (``'*'``: any);
    programs, which send no ``Origin``, always.
    """

    port: int = FOXGLOVE_PORT
    address: str = '127.0.0.1'
    tls_cert: str | os.PathLike[str] | None = None
    tls_key: str | os.PathLike[str] | None = None
    message_backlog: int = DEFAULT_BACKLOG
    name: str = 'zros'
    allow_origins: tuple[str, ...] = (FOXGLOVE_APP,)
    client_buffer: int = CLIENT_BUFFER
    max_clients: int = MAX_CLIENTS

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
        if self.client_buffer < 1:
            raise GatewayError(
                f'the client buffer must be at least 1 byte, not {self.client_buffer}'
            )
        check_max_clients(self.max_clients)

    def start(self, **settings: Unpack[SdkOptions]) -> tuple[WebSocketServer, FrontProcess]:
        """Start the SDK's server with these options and ``settings`` (capabilities, listener,
        context...), and the front clients reach it through, in a process of its own;
        GatewayError when either cannot listen."""
        foxglove = import_sdk()
        self.check()
        bound_sdk_logs()
        listener = settings.pop('server_listener', None)
        listen = self._listen()
        host = private_loopback()
        try:
            server: WebSocketServer = foxglove.start_server(
                name=self.name,
                host=host,
                port=0,
                message_backlog_size=self.message_backlog,
                server_listener=cast('ServerListener | None', listener),
                **settings,
            )
        except RuntimeError as exc:  # the SDK's FoxgloveError
            raise GatewayError(f'cannot start the Foxglove server on {host}: {exc}') from None
        try:
            front = FrontProcess(
                listen,
                (host, server.port),
                self.allow_origins,
                self.client_buffer,
                self.max_clients,
            )
        except BaseException:
            server.stop()
            raise
        return server, front

    def url(self, port: int) -> str:
        """The address clients open."""
        return self._listen().url(port)


def ros2msg_schema(registry: TypeRegistry, type_name: str) -> foxglove.Schema | None:
    """The Foxglove schema of a ROS type: the ``ros2msg`` text with its dependencies, as
    rosbag2 writes it into MCAP files; None when the registry does not know the type."""
    import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

    from zros.cdr.render import render_bundle  # noqa: PLC0415 (zros.foxglove stays light: no numpy)

    try:
        text = render_bundle(registry, type_name)
    except ZrosError as exc:
        _log.warning('no definition of %s: Foxglove gets no schema for it (%s)', type_name, exc)
        return None
    return foxglove.Schema(name=type_name, encoding='ros2msg', data=text.encode())


def connection_graph(
    published: dict[str, list[str]],
    subscribed: dict[str, list[str]],
    providers: dict[str, list[str]],
) -> foxglove.ConnectionGraph:
    """The SDK's connection graph: the ids of the nodes publishing and subscribing each topic
    and providing each service."""
    import foxglove  # noqa: PLC0415 (optional: the foxglove extra)

    graph = foxglove.ConnectionGraph()
    for name, ids in published.items():
        graph.set_published_topic(name, ids)
    for name, ids in subscribed.items():
        graph.set_subscribed_topic(name, ids)
    for name, ids in providers.items():
        graph.set_advertised_service(name, ids)
    return graph
