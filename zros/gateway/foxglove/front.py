"""The public door of ``zros foxglove``: a small WebSocket front before the Foxglove SDK's server.

The SDK's server accepts one subprotocol (``foxglove.sdk.v1``), has no hook for the ``Origin``
of a browser, and bounds a client's outbox in messages, not bytes. The front listens on the
public address (with TLS, if any) and, per connection:

* reads the HTTP upgrade request: an ``Origin`` that
  :class:`~zros.gateway.common.origins.OriginPolicy` refuses gets HTTP 403;
  ``foxglove.websocket.v1`` (the ``@foxglove/ws-protocol`` clients, Lichtblick) becomes
  ``foxglove.sdk.v1`` on the way in, and the answer names the one the client offered on the
  way out (after the handshake the two are the same protocol);
* relays the connection to the SDK's server, which listens in plain text on a loopback port of
  its own, in one thread: the client's bytes go through unread; the server's frames are only
  delimited (their headers read, the server's frames are unmasked), and pass in big sends while
  the client keeps up. When it does not, its frames queue here, bounded in bytes
  (``client_buffer``): past it the oldest message data frames are dropped (never a text or
  control frame), the client gets a warning status (at most one a second) and the log counts
  the drops. The SDK's side is always read, so neither it nor Zenoh waits for a slow client.

At most ``max_clients`` connections are served at once, handshakes included (each has a
thread, and once upgraded a buffer of a megabyte); past that a connection gets HTTP 503
(:mod:`~zros.gateway.common.admission`).

This module listens; :mod:`~zros.gateway.foxglove.handshake` reads and rewrites the upgrade,
:mod:`~zros.gateway.foxglove.relay` relays one connection and queues its frames,
:mod:`~zros.gateway.foxglove.ws_frames` delimits them. ``zros foxglove`` runs the front in a
process of its own, off the gateway's GIL (:mod:`zros.gateway.foxglove.front_process`): these
modules import nothing of Zenoh or the SDK.
"""

from __future__ import annotations

import contextlib
import logging
import secrets
import socket
import threading
from typing import TYPE_CHECKING

from zros.gateway.common.admission import Admission
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.limits import MAX_CLIENTS
from zros.gateway.foxglove.relay import Connection

if TYPE_CHECKING:
    from zros.gateway.common.listen import Listen
    from zros.gateway.common.origins import OriginPolicy

_log = logging.getLogger('zros.gateway')


class Front:
    """Listens where ``listen`` says and relays each connection to the SDK's server at
    ``upstream``, at most ``max_clients`` at once (see the module docstring); ``port`` is the
    port it got."""

    def __init__(
        self,
        listen: Listen,
        upstream: tuple[str, int],
        origins: OriginPolicy,
        client_buffer: int,
        max_clients: int = MAX_CLIENTS,
    ) -> None:
        self.server_address = upstream  #: the SDK's server
        self.origins = origins
        self.client_buffer = client_buffer
        self.admission = Admission(max_clients)
        self.tls = listen.ssl_context()
        try:
            self._socket = socket.create_server(
                (listen.address, listen.port),
                family=socket.AF_INET6 if ':' in listen.address else socket.AF_INET,
            )
        except OSError as exc:
            raise GatewayError(
                f'cannot start the Foxglove server on {listen.address}:{listen.port}: {exc}'
            ) from None
        self.port: int = self._socket.getsockname()[1]
        #: readable once the front closes (every connection's loop watches it)
        self.closing, self._stop_w = socket.socketpair()
        self._lock = threading.Lock()
        self._threads: dict[threading.Thread, socket.socket] = {}  # and their clients
        self._closed = False
        self.dropped = 0  #: message frames dropped for slow clients, all clients together
        self.reported = 0  #: warnings sent to slow clients
        self._thread = threading.Thread(
            target=self._accept, name='zros foxglove front', daemon=True
        )
        self._thread.start()

    def _accept(self) -> None:
        while True:
            try:
                client, address = self._socket.accept()
            except OSError:
                return  # closed
            if not self.admission.enter(client):
                if self.tls is None:
                    _refuse(client, self.admission.refusal())
                else:  # a TLS handshake would hold the accepting thread
                    client.close()
                continue
            with self._lock:
                if self._closed:
                    client.close()
                    return
                thread = threading.Thread(
                    target=self._serve,
                    args=(client, address),
                    name='zros foxglove client',
                    daemon=True,
                )
                self._threads[thread] = client
            thread.start()

    def _serve(self, client: socket.socket, address: tuple[object, ...]) -> None:
        name = f'{address[0]}:{address[1]}'
        try:
            Connection(self, client, name).run()
        except Exception:  # one client's failure never reaches the others
            _log.debug('the connection of %s failed', name, exc_info=True)
        finally:
            self.admission.leave(client)
            with self._lock:
                self._threads.pop(threading.current_thread(), None)

    def close(self) -> None:
        """Stop listening and end every connection."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            threads = dict(self._threads)
        with contextlib.suppress(OSError):  # wakes the accepting thread (close alone does not)
            self._socket.shutdown(socket.SHUT_RDWR)
        self._socket.close()
        self._stop_w.send(b'x')  # never read: every connection's loop sees it and ends
        for client in threads.values():  # and a connection still in its handshake
            with contextlib.suppress(OSError):
                client.shutdown(socket.SHUT_RDWR)
        for thread in [self._thread, *threads]:
            thread.join(5.0)
        self.closing.close()
        self._stop_w.close()


def _refuse(client: socket.socket, text: str) -> None:
    """Answer a connection over the bound with HTTP 503 (without waiting for its request or
    on a full socket: the accepting thread must not block) and close it."""
    body = text.encode()
    with contextlib.suppress(OSError), client:
        client.setblocking(False)
        client.send(
            b'HTTP/1.1 503 Service Unavailable\r\nContent-Type: text/plain; charset=utf-8\r\n'
            b'Content-Length: %d\r\nConnection: close\r\n\r\n%s' % (len(body), body)
        )


def private_loopback() -> str:
    """A loopback address for the SDK's server that a web page cannot guess: a random one of
    127.0.0.0/8 where the system answers on all of it (Linux), else 127.0.0.1."""
    address = (
        f'127.{secrets.randbelow(254) + 1}.{secrets.randbelow(256)}.{secrets.randbelow(254) + 1}'
    )
    try:
        with socket.socket() as probe:
            probe.bind((address, 0))
    except OSError:
        return '127.0.0.1'
    return address
