"""``zros rosbridge``: the rosbridge v2 protocol over a WebSocket, for web apps built on
roslibjs and roslibpy, in front of the ROS graph reached over Zenoh.

The server is the websockets library's threaded server (the ``rosbridge`` extra): each client
has a thread reading its messages (:mod:`~zros.gateway.rosbridge.client`) and one writing its
bounded outbox. Topics (:mod:`~zros.gateway.rosbridge.topics`) are tapped raw, only while a
client subscribes, and each message is converted once per form (JSON, CBOR, raw CDR, PNG)
whatever the number of clients. Services, client-served services and actions
(:mod:`~zros.gateway.rosbridge.calls`), and actions clients serve
(:mod:`~zros.gateway.rosbridge.served_actions`) go through zros clients and servers;
rosapi's services (:mod:`~zros.gateway.rosbridge.rosapi`) are answered by the gateway itself.

The gateway spins the node it is given (client-served services, the cancel callbacks of
client-served actions and action feedback run there):
give it a node of its own.

What a client may do is bounded (:class:`Limits`): browsers are accepted by the ``Origin`` of
their page (:class:`~zros.gateway.common.origins.OriginPolicy`), a read-only gateway refuses
every op that acts on the robot, a client may not take over a service or action another node serves,
each client's outbox holds at most ``client_buffer`` bytes, and at most ``max_clients`` clients
are served at once (:mod:`~zros.gateway.common.admission`).
"""

from __future__ import annotations

import http
import itertools
import logging
import os
import threading
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from zros.closing import Closing
from zros.gateway.common.admission import Admission
from zros.gateway.common.entities import start_gateway
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.common.limits import CLIENT_BUFFER, MAX_CLIENTS, ROSBRIDGE_PORT
from zros.gateway.common.listen import Listen
from zros.gateway.common.origins import OriginPolicy
from zros.gateway.common.throttle import Throttle
from zros.gateway.common.watched_topics import Taps
from zros.gateway.rosbridge.calls import Calls
from zros.gateway.rosbridge.client import ClientSession
from zros.gateway.rosbridge.conversion import Values
from zros.gateway.rosbridge.rosapi import Rosapi
from zros.gateway.rosbridge.topics import Topics
from zros.version import install_hint

if TYPE_CHECKING:
    from types import ModuleType

    from typing_extensions import Unpack
    from websockets.http11 import Request, Response
    from websockets.sync.server import ServerConnection

    from zros.node import Node
    from zros.node.settings import NodeKeywords

_log = logging.getLogger('zros.gateway')

#: rosbridge_server's ``max_message_size``: larger client messages close the connection,
#: larger JSON messages to clients go as fragments
MAX_MESSAGE_SIZE = 10_000_000
#: a client's outbox: messages, and bytes
QUEUE_ITEMS = 1000
#: seconds a closing client has to answer the close handshake
CLOSE_TIMEOUT = 2.0


def import_websockets() -> ModuleType:
    """The websockets server module; GatewayError says how to install it."""
    try:
        from websockets.sync import server  # noqa: PLC0415 (optional: the rosbridge extra)
    except ImportError:
        raise GatewayError(
            f'the websockets library is not installed: {install_hint("rosbridge")}'
        ) from None
    return server


@dataclass(frozen=True)
class Limits:
    """What clients may do: ``read_only`` refuses every op that acts on the robot (publishing,
    service calls, parameter sets, action goals, services and actions served by a client);
    ``allow_service_override`` lets a client serve a service or action another node of the
    graph serves already."""

    read_only: bool = False
    allow_service_override: bool = False


class RosbridgeGateway(Closing):
    """A rosbridge v2 server showing the graph ``node`` sees (see the module docstring).

    ``topics_glob``, ``services_glob`` and ``params_glob`` are allow-lists of shell globs as
    rosbridge's (every name when empty); ``max_message_size`` bounds what a client may send in
    one message; ``queue_items`` and ``client_buffer`` (bytes) bound each client's outbox;
    at most ``max_clients`` are served at once (others get HTTP 503).
    ``allow_origins``: the origins of web pages accepted besides this machine's (``'*'``: any);
    ``limits``: what clients may do. ``own_node``: the gateway made ``node`` and destroys it on
    :meth:`close`.
    """

    def __init__(
        self,
        node: Node,
        listen: Listen,
        *,
        topics_glob: Iterable[str] | None = None,
        services_glob: Iterable[str] | None = None,
        params_glob: Iterable[str] | None = None,
        max_message_size: int = MAX_MESSAGE_SIZE,
        queue_items: int = QUEUE_ITEMS,
        client_buffer: int = CLIENT_BUFFER,
        max_clients: int = MAX_CLIENTS,
        allow_origins: Iterable[str] = (),
        limits: Limits = Limits(),
        own_node: bool = False,
        throttle: Iterable[str] = (),
    ) -> None:
        server_module = import_websockets()
        listen.check()
        if max_message_size < 1 or queue_items < 1 or client_buffer < 1:
            raise GatewayError('the message size and the queue bounds must be at least 1')
        context = listen.ssl_context()
        self.node = node
        self._own_node = own_node
        self._sizes = (max_message_size, queue_items, client_buffer)
        self.origins = OriginPolicy(allow_origins)
        self.admission = Admission(max_clients)
        self.limits = limits
        if limits.read_only:
            _log.info('read-only: clients may watch the robot, not act on it')
        self.values = Values(node.registry, self._now)
        self._taps = Taps(
            node, lambda: node.now().nanoseconds, limit=Throttle.parse(throttle).limit
        )
        self.topics = Topics(node, self.values, NameFilter.globs(topics_glob), self._taps)
        rosapi = Rosapi(
            node,
            NameFilter.globs(topics_glob),
            NameFilter.globs(services_glob),
            NameFilter.globs(params_glob),
        )
        self.calls = Calls(
            node,
            self.values,
            NameFilter.globs(services_glob),
            rosapi,
            allow_override=limits.allow_service_override,
        )
        self._lock = threading.Lock()
        self._clients: dict[int, ClientSession] = {}
        self._ids = itertools.count(1)
        self._closed = threading.Event()
        try:
            self._server = server_module.serve(
                self._serve_client,
                listen.address,
                listen.port,
                ssl=context,
                max_size=max_message_size,
                compression=None,
                close_timeout=CLOSE_TIMEOUT,
                server_header='zros rosbridge',
                process_request=self._check_request,
            )
        except OSError as exc:
            self._close_parts()
            raise GatewayError(
                f'cannot start the rosbridge server on {listen.address}:{listen.port}: '
                f'{exc.strerror or exc}'
            ) from None
        self.port: int = self._server.socket.getsockname()[1]
        self.url = listen.url(self.port)
        self._threads = [
            threading.Thread(target=self._server.serve_forever, name='zros rosbridge', daemon=True),
            threading.Thread(target=self._spin, name='zros rosbridge spin', daemon=True),
        ]
        for thread in self._threads:
            thread.start()
        _log.info('rosbridge server on %s (%s wire)', self.url, node.wire)

    def _now(self) -> tuple[int, int]:
        sec, nanosec = divmod(self.node.now().nanoseconds, 1_000_000_000)
        return sec, nanosec

    def _spin(self) -> None:
        while not self._closed.is_set() and self.node.ok():
            self.node.spin_once(0.2)

    def _check_request(self, connection: ServerConnection, request: Request) -> Response | None:
        """Refuse the upgrade of a web page whose origin is not accepted (HTTP 403), and any
        over the bound of clients (HTTP 503)."""
        origins = request.headers.get_all('Origin')
        if len(origins) > 1:  # browsers send one: refused whole, not by its first
            origin: str | None = ', '.join(origins)
        else:
            origin = origins[0] if origins else None
        if len(origins) > 1 or not self.origins.accepts(origin):
            return connection.respond(http.HTTPStatus.FORBIDDEN, self.origins.refuse(str(origin)))
        if not self.admission.enter(connection):
            refusal = self.admission.refusal()
            return connection.respond(http.HTTPStatus.SERVICE_UNAVAILABLE, refusal)
        return None

    def _serve_client(self, connection: ServerConnection) -> None:
        max_message_size, queue_items, client_buffer = self._sizes
        client = ClientSession(
            next(self._ids),
            connection,
            self.topics,
            self.calls,
            max_message_size=max_message_size,
            queue_items=queue_items,
            queue_bytes=client_buffer,
            read_only=self.limits.read_only,
        )
        with self._lock:
            if self._closed.is_set():
                self.admission.leave(connection)
                return
            self._clients[client.id] = client
        _log.info('client %d connected from %s', client.id, connection.remote_address)
        try:
            client.run()
        finally:
            with self._lock:
                self._clients.pop(client.id, None)
            self.admission.leave(connection)
            _log.info('client %d left', client.id)

    # --- the user's side -----------------------------------------------------------------------

    @property
    def clients(self) -> list[ClientSession]:
        """The clients connected now."""
        with self._lock:
            return list(self._clients.values())

    def watched(self) -> dict[str, int]:
        """The topics with a Zenoh subscription now, and how many client subscriptions each."""
        return self._taps.watched()

    def _close_parts(self) -> None:
        self.topics.close()
        self.calls.close()
        self._taps.close()

    def close(self) -> None:
        """Stop the server, disconnect the clients and release every Zenoh entity (and the
        node, if the gateway made it)."""
        if self._closed.is_set():
            return
        self._closed.set()
        from websockets.protocol import State  # noqa: PLC0415 (optional: the rosbridge extra)

        for client in self.clients:
            if client.connection.state is State.OPEN:
                client.connection.close()  # the close handshake, CLOSE_TIMEOUT at most
            client.connection.close_socket()  # a client gone silent holds no thread
        self._server.shutdown()
        for thread in self._threads:
            thread.join(5.0)
        self._close_parts()
        if self._own_node:
            self.node.destroy()

    def __repr__(self) -> str:
        return f'<zros RosbridgeGateway {self.url} ({len(self._clients)} clients)>'


def serve(
    *,
    port: int = ROSBRIDGE_PORT,
    address: str = '127.0.0.1',
    topics_glob: Iterable[str] | None = None,
    services_glob: Iterable[str] | None = None,
    params_glob: Iterable[str] | None = None,
    tls_cert: str | os.PathLike[str] | None = None,
    tls_key: str | os.PathLike[str] | None = None,
    max_message_size: int = MAX_MESSAGE_SIZE,
    queue_items: int = QUEUE_ITEMS,
    client_buffer: int = CLIENT_BUFFER,
    max_clients: int = MAX_CLIENTS,
    allow_origins: Iterable[str] = (),
    read_only: bool = False,
    allow_service_override: bool = False,
    node: Node | None = None,
    name: str = 'zros_rosbridge',
    throttle: Iterable[str] = (),
    **settings: Unpack[NodeKeywords],
) -> RosbridgeGateway:
    """Serve the robot to rosbridge clients at ``ws://address:port``; returns the running
    server (``close()`` it, or use ``with``).

    Without ``node``, a node named ``name`` joins the graph with the connection ``settings``
    of :class:`zros.Node` (``connect``, ``wire``, ``transport``, ``tls``...). The gateway spins
    its node: a node given here should be one nothing else spins.

    Web pages of other machines are refused unless ``allow_origins`` lists their origin;
    ``read_only`` lets clients watch only; ``allow_service_override`` lets a client serve a
    service another node serves; ``client_buffer`` bounds the bytes queued for each client,
    ``max_clients`` the clients served at once (others get HTTP 503);
    ``throttle`` holds ``REGEX=HZ`` rate limits of topics (:mod:`zros.gateway.common.throttle`).
    """
    listen = Listen(port, address, tls_cert, tls_key, 'the rosbridge server')
    return start_gateway(node, name, settings, lambda node, own: RosbridgeGateway(
        node,
        listen,
        topics_glob=topics_glob,
        services_glob=services_glob,
        params_glob=params_glob,
        max_message_size=max_message_size,
        queue_items=queue_items,
        client_buffer=client_buffer,
        max_clients=max_clients,
        allow_origins=allow_origins,
        limits=Limits(read_only, allow_service_override),
        own_node=own,
        throttle=throttle,
    ))  # fmt: skip
