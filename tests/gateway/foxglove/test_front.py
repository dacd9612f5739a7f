"""The front of ``zros foxglove`` on its own, before a stand-in of the SDK's server: what it
drops for a client that does not read (message data only, the oldest first), and what it
tells that client."""

from __future__ import annotations

import json
import socket
import threading
from collections.abc import Iterator

import pytest

from zros.gateway.common.listen import Listen
from zros.gateway.common.origins import OriginPolicy
from zros.gateway.foxglove.front import SDK_SUBPROTOCOL, Front
from zros.testing import wait_for

TIMEOUT = 20.0
#: message sizes and counts: 20 MB and 45 MB, more than the sockets and the bound hold
#: (messages of 1.5 MB are larger than what the front reads at once: they move in the kernel
#: while the client keeps up, and into a buffer of their own when it stops)
SIZES = {'100kB': (100_000, 200), '1.5MB': (1_500_000, 30)}


def _frame(opcode: int, payload: bytes) -> bytes:
    """A server's (unmasked) WebSocket frame."""
    size = len(payload)
    if size < 126:
        return bytes((0x80 | opcode, size)) + payload
    if size < 65536:
        return bytes((0x80 | opcode, 126)) + size.to_bytes(2, 'big') + payload
    return bytes((0x80 | opcode, 127)) + size.to_bytes(8, 'big') + payload


def _read_frames(sock: socket.socket) -> list[tuple[int, bytes]]:
    """Every frame until the peer closes: (opcode, payload)."""
    data = bytearray()
    while chunk := sock.recv(1 << 20):
        data += chunk
    frames, position = [], 0
    while position < len(data):
        opcode, size = data[position] & 0x0F, data[position + 1] & 0x7F
        position += 2
        if size >= 126:
            width = 2 if size == 126 else 8
            size = int.from_bytes(data[position : position + width], 'big')
            position += width
        frames.append((opcode, bytes(data[position : position + size])))
        position += size
    return frames


class _Server:
    """A stand-in of the SDK's server: answers one upgrade, then sends ``frames`` and closes."""

    def __init__(self, frames: list[bytes]) -> None:
        self.socket = socket.create_server(('127.0.0.1', 0))
        self.port = self.socket.getsockname()[1]
        self.request = b''
        self.sent = threading.Event()
        self._frames = frames
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        connection, _ = self.socket.accept()
        with connection:
            while b'\r\n\r\n' not in self.request:
                self.request += connection.recv(4096)
            connection.sendall(
                b'HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\n'
                b'Connection: Upgrade\r\nSec-WebSocket-Accept: x\r\n'
                b'Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n'
            )
            connection.sendall(b''.join(self._frames))
            self.sent.set()

    def close(self) -> None:
        self.socket.close()
        self._thread.join(TIMEOUT)


@pytest.fixture
def front() -> Iterator[list[Front]]:
    made: list[Front] = []
    yield made
    for item in made:
        item.close()


def _message(index: int, size: int) -> bytes:
    return bytes([1]) + index.to_bytes(4, 'little') + bytes([index % 251]) * size


def _upgrade(port: int, receive_buffer: int | None = None) -> socket.socket:
    client = socket.socket()
    if receive_buffer is not None:
        client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, receive_buffer)
    client.connect(('127.0.0.1', port))
    client.sendall(
        b'GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n'
        b'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n'
        b'Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n'
    )
    return client


def _head(client: socket.socket) -> bytes:
    head = b''
    while b'\r\n\r\n' not in head:
        head += client.recv(1)
    return head


@pytest.mark.parametrize(('size', 'count'), SIZES.values(), ids=SIZES)
def test_a_client_that_reads_gets_every_byte(front: list[Front], size: int, count: int) -> None:
    frames = [_frame(0x2, _message(index, size)) for index in range(count)]
    server = _Server(frames)
    served = Front(Listen(0), ('127.0.0.1', server.port), OriginPolicy(), 2 * size * count)
    front.append(served)
    client = _upgrade(served.port)
    _head(client)
    received = _read_frames(client)
    client.close()
    server.close()
    assert [payload for _, payload in received] == [_message(i, size) for i in range(count)]
    assert served.dropped == 0


@pytest.mark.parametrize(('size', 'count'), SIZES.values(), ids=SIZES)
def test_a_client_that_does_not_read_loses_only_its_oldest_messages(
    front: list[Front], size: int, count: int
) -> None:
    frames, texts = [], []
    for index in range(count):
        frames.append(_frame(0x2, _message(index, size)))
        if index % 10 == 0:
            text = json.dumps({'op': 'advertise', 'channels': [], 'n': index}).encode()
            texts.append(text)
            frames.append(_frame(0x1, text))
            frames.append(_frame(0x2, bytes([2]) + index.to_bytes(8, 'little')))  # a time
    server = _Server(frames)
    served = Front(Listen(0), ('127.0.0.1', server.port), OriginPolicy(), 4 * size)
    front.append(served)
    client = _upgrade(served.port, receive_buffer=4096)  # then reads nothing for a while
    assert server.sent.wait(TIMEOUT)  # the front took all of it while the client slept
    assert wait_for(lambda: served.dropped > 0, TIMEOUT)
    assert b'Sec-WebSocket-Protocol: foxglove.websocket.v1' in _head(client)
    assert f'Sec-WebSocket-Protocol: {SDK_SUBPROTOCOL}'.encode() in server.request
    received = _read_frames(client)
    client.close()
    server.close()
    messages = [p for op, p in received if op == 0x2 and p[0] == 1]
    data = [int.from_bytes(p[1:5], 'little') for p in messages]
    assert messages == [_message(i, size) for i in data]  # whole
    statuses = [json.loads(p) for op, p in received if op == 0x1 and b'"status"' in p]
    assert [p for op, p in received if op == 0x1 and b'advertise' in p] == texts  # all, in order
    assert len([p for op, p in received if op == 0x2 and p[0] == 2]) == count // 10
    assert data == sorted(data) and data[-1] == count - 1  # the newest arrive, in order
    assert len(data) + served.dropped == count
    assert served.dropped >= count // 4  # past the sockets' buffers and the bound
    assert 1 <= len(statuses) == served.reported
    assert statuses[0]['level'] == 1 and 'does not read fast enough' in statuses[0]['message']


def test_the_sdk_listens_where_a_page_cannot_guess() -> None:
    """A web page may try ws://127.0.0.1:PORT for every port; on Linux the SDK's server, which
    checks no Origin, listens on a random address of 127.0.0.0/8 instead."""
    import ipaddress
    import sys

    from zros.gateway.foxglove.front import private_loopback

    addresses = {private_loopback() for _ in range(5)}
    assert all(ipaddress.ip_address(a).is_loopback for a in addresses)
    if sys.platform.startswith('linux'):
        assert '127.0.0.1' not in addresses and len(addresses) > 1


def test_closing_ends_a_connection_still_in_its_handshake(front: list[Front]) -> None:
    import time

    served = Front(Listen(0), ('127.0.0.1', 9), OriginPolicy(), 1000)
    with socket.create_connection(('127.0.0.1', served.port)) as silent:
        silent.sendall(b'GET / HTTP/1.1\r\n')  # and nothing more
        assert wait_for(lambda: len(served._threads) == 1, TIMEOUT)
        start = time.monotonic()
        served.close()
        assert time.monotonic() - start < 2.0  # not the handshake's timeout
        assert silent.recv(10) == b''
