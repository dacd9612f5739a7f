"""The upgrade of a connection to the Foxglove front: the HTTP heads, read and rewritten.

An ``Origin`` that :class:`~zros.gateway.common.origins.OriginPolicy` refuses gets HTTP 403;
``foxglove.websocket.v1`` (the ``@foxglove/ws-protocol`` clients, Lichtblick) becomes
``foxglove.sdk.v1`` on the way in, and the answer names the one the client offered on the way
out (after the handshake the two are the same protocol).
"""

from __future__ import annotations

import socket
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zros.gateway.common.origins import OriginPolicy

#: the subprotocol the SDK's server speaks
SDK_SUBPROTOCOL = 'foxglove.sdk.v1'
#: the subprotocols the front accepts (the same protocol under two names)
SUBPROTOCOLS = ('foxglove.websocket.v1', SDK_SUBPROTOCOL)
#: the longest HTTP request or response head accepted
MAX_HEAD = 16 * 1024
#: seconds a client has for its TLS handshake and upgrade request, and for each head in all
#: (a client sending a byte now and then must not hold its place for hours)
HANDSHAKE_TIMEOUT = 10.0


class Head:
    """An HTTP request or response head: its first line and header lines, as sent."""

    def __init__(self, data: bytes) -> None:
        lines = data.decode('latin-1').split('\r\n')
        self.first = lines[0]
        self.headers = [line for line in lines[1:] if line]

    def values(self, name: str) -> list[str]:
        """The values of every header ``name`` (comma lists split)."""
        found = []
        for line in self.headers:
            key, _, value = line.partition(':')
            if key.strip().lower() == name:
                found += [v.strip() for v in value.split(',') if v.strip()]
        return found

    def first_value(self, name: str) -> str | None:
        for line in self.headers:
            key, _, value = line.partition(':')
            if key.strip().lower() == name:
                return value.strip()
        return None

    def replace(self, name: str, value: str) -> None:
        """Every header ``name`` becomes one, of ``value``."""
        kept = [
            line for line in self.headers if line.partition(':')[0].strip().lower() != name.lower()
        ]
        self.headers = [*kept, f'{name}: {value}']

    def encode(self) -> bytes:
        return '\r\n'.join([self.first, *self.headers, '', '']).encode('latin-1')


def read_head(sock: socket.socket) -> tuple[bytes, bytes] | None:
    """An HTTP head read from ``sock`` (blocking) and the bytes after it; None when the peer
    closed or sent more than MAX_HEAD without ending it; TimeoutError when the whole head
    took longer than :data:`HANDSHAKE_TIMEOUT`."""
    deadline = time.monotonic() + HANDSHAKE_TIMEOUT
    data = b''
    while b'\r\n\r\n' not in data:
        if len(data) > MAX_HEAD:
            return None
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError(f'no whole HTTP head in {HANDSHAKE_TIMEOUT:g} s')
        sock.settimeout(left)
        chunk = sock.recv(4096)
        if not chunk:
            return None
        data += chunk
    head, _, rest = data.partition(b'\r\n\r\n')
    return head, rest


def read_upgrade(client: socket.socket, origins: OriginPolicy) -> Upgrade | None:
    """The client's upgrade request (read blocking), its subprotocol renamed for the server;
    None when the connection ends here (closed, too long a head, a refused ``Origin``)."""
    read = read_head(client)
    if read is None:
        return None
    request, rest = Head(read[0]), read[1]
    origin = request.first_value('origin')
    if origin is not None and not origins.accepts(origin):
        body = origins.refuse(origin).encode()
        client.sendall(
            b'HTTP/1.1 403 Forbidden\r\nContent-Type: text/plain; charset=utf-8\r\n'
            b'Content-Length: %d\r\nConnection: close\r\n\r\n%b' % (len(body), body)
        )
        return None
    offered = request.values('sec-websocket-protocol')
    chosen = next((p for p in offered if p in SUBPROTOCOLS), None)
    if chosen is not None:
        request.replace('Sec-WebSocket-Protocol', SDK_SUBPROTOCOL)
    return Upgrade(request, rest, chosen)


@dataclass
class Upgrade:
    """A client's upgrade request as the server gets it."""

    request: Head
    rest: bytes  #: what the client sent after the request
    chosen: str | None  #: the subprotocol the client offered, under its name

    def relay(self, upstream: socket.socket, client: socket.socket) -> bytes | None:
        """Send the request to the server and its answer to the client (the subprotocol
        named as the client offered it); what the server sent after the answer, None when it
        closed first."""
        upstream.sendall(self.request.encode() + self.rest)
        answer = read_head(upstream)
        if answer is None:
            return None
        response, after = Head(answer[0]), answer[1]
        if self.chosen is not None and response.first_value('sec-websocket-protocol') is not None:
            response.replace('Sec-WebSocket-Protocol', self.chosen)
        client.sendall(response.encode())
        return after
