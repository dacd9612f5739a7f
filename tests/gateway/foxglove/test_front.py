"""The front of ``zros foxglove`` on its own, before a stand-in of the SDK's server: what it
drops for a client that does not read (message data only, the oldest first), and what it
tells that client."""

from __future__ import annotations

import json
import logging
import os
import socket
import threading
from collections.abc import Iterator

import pytest

from zros.gateway.common.errors import GatewayError
from zros.gateway.common.listen import Listen
from zros.gateway.common.origins import OriginPolicy
from zros.gateway.foxglove.front import Front
from zros.gateway.foxglove.front_process import FrontProcess
from zros.gateway.foxglove.handshake import SDK_SUBPROTOCOL
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
def front() -> Iterator[list[Front | FrontProcess]]:
    """The fronts a test made, in its process or in their own, closed after it."""
    made: list[Front | FrontProcess] = []
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
def test_a_client_that_reads_gets_every_byte(
    front: list[Front | FrontProcess], size: int, count: int
) -> None:
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
    front: list[Front | FrontProcess], size: int, count: int
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


def test_closing_ends_a_connection_still_in_its_handshake(
    front: list[Front | FrontProcess],
) -> None:
    import time

    served = Front(Listen(0), ('127.0.0.1', 9), OriginPolicy(), 1000)
    with socket.create_connection(('127.0.0.1', served.port)) as silent:
        silent.sendall(b'GET / HTTP/1.1\r\n')  # and nothing more
        assert wait_for(lambda: len(served._threads) == 1, TIMEOUT)
        start = time.monotonic()
        served.close()
        assert time.monotonic() - start < 2.0  # not the handshake's timeout
        assert silent.recv(10) == b''


def _refused(port: int) -> bytes:
    """What a connection over the bound gets before the front closes it."""
    with socket.create_connection(('127.0.0.1', port), timeout=TIMEOUT) as client:
        answer = b''
        while chunk := client.recv(4096):
            answer += chunk
    return answer


def test_connections_over_the_bound_get_503_and_a_place_frees_when_one_leaves(
    front: list[Front | FrontProcess], caplog: pytest.LogCaptureFixture
) -> None:
    server = _Server([])
    served = Front(Listen(0), ('127.0.0.1', server.port), OriginPolicy(), 1000, max_clients=2)
    front.append(served)
    silent = [socket.create_connection(('127.0.0.1', served.port)) for _ in range(2)]
    assert wait_for(lambda: len(served.admission) == 2, TIMEOUT)
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        answer = _refused(served.port)
    assert answer.startswith(b'HTTP/1.1 503 Service Unavailable\r\n')
    assert answer.endswith(b'at most 2 clients at once (--max-clients raises it)')
    assert 'refused 1 connection: the server serves at most 2 clients' in caplog.text
    silent[0].close()
    assert wait_for(lambda: len(served.admission) == 1, TIMEOUT)
    client = _upgrade(served.port)
    assert b' 101 ' in _head(client)
    client.close()
    silent[1].close()
    server.close()


def _resident() -> int:
    with open('/proc/self/statm') as statm:
        return int(statm.read().split()[1]) * os.sysconf('SC_PAGE_SIZE')


@pytest.mark.skipif(not os.path.exists('/proc/self/statm'), reason='reads /proc (Linux)')
def test_a_connection_that_never_upgrades_holds_no_buffer(
    front: list[Front | FrontProcess],
) -> None:
    # each connection's megabyte for the server's frames is taken once it is upgraded: a
    # program opening connections and sending nothing cost 1 GB a thousand
    count = 60
    served = Front(Listen(0), ('127.0.0.1', 9), OriginPolicy(), 1000, max_clients=count)
    front.append(served)
    before = _resident()
    silent = [socket.create_connection(('127.0.0.1', served.port)) for _ in range(count)]
    assert wait_for(lambda: len(served.admission) == count, TIMEOUT)
    grown = _resident() - before
    for client in silent:
        client.close()
    assert grown < count * 2**20 // 3, f'{count} idle connections took {grown / 2**20:.0f} MB'


# --- the front in a process of its own -----------------------------------------------------


def test_the_process_reports_its_drops_and_warnings_to_the_gateway(
    front: list[Front | FrontProcess], caplog: pytest.LogCaptureFixture
) -> None:
    """The counters and the log lines of the front's process reach the gateway's process."""
    size, count = SIZES['100kB']
    server = _Server([_frame(0x2, _message(index, size)) for index in range(count)])
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        served = FrontProcess(Listen(0), ('127.0.0.1', server.port), (), 4 * size)
        front.append(served)
        client = _upgrade(served.port, receive_buffer=4096)  # then reads nothing for a while
        assert server.sent.wait(TIMEOUT)
        assert wait_for(lambda: served.dropped > 0 and served.reported > 0, TIMEOUT)
        assert wait_for(lambda: 'does not read fast enough' in caplog.text, TIMEOUT)
        assert b' 101 ' in _head(client)
        received = _read_frames(client)
        client.close()
        server.close()
        served.close()
    assert served._process.returncode == 0
    messages = [p for op, p in received if op == 0x2 and p[0] == 1]
    assert len(messages) + served.dropped == count  # the last counts came before it ended
    assert served.reported == len([p for op, p in received if op == 0x1])


def test_an_error_of_the_process_is_the_gateways_error(
    front: list[Front | FrontProcess],
) -> None:
    with socket.socket() as taken:
        taken.bind(('127.0.0.1', 0))
        taken.listen()
        port = taken.getsockname()[1]
        with pytest.raises(
            GatewayError, match=f'cannot start the Foxglove server on 127.0.0.1:{port}: '
        ):
            FrontProcess(Listen(port), ('127.0.0.1', 9), (), 1000)


def test_a_refused_origin_is_logged_by_the_gateway(
    front: list[Front | FrontProcess], caplog: pytest.LogCaptureFixture
) -> None:
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        served = FrontProcess(Listen(0), ('127.0.0.1', 9), ('*',), 1000)
        front.append(served)
        assert 'every web page may open this gateway' in caplog.text  # said before it listens
    served.close()
    served = FrontProcess(Listen(0), ('127.0.0.1', 9), (), 1000)
    front.append(served)
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        with socket.create_connection(('127.0.0.1', served.port)) as client:
            client.sendall(
                b'GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n'
                b'Origin: https://evil.example\r\n\r\n'
            )
            assert _head(client).startswith(b'HTTP/1.1 403')
        assert wait_for(lambda: 'https://evil.example' in caplog.text, TIMEOUT)


def test_the_process_imports_neither_zenoh_nor_the_sdk(
    front: list[Front | FrontProcess],
) -> None:
    """What the front's process imports: its module, and nothing of Zenoh, the SDK or numpy
    (they would cost memory and start-up time in a process that only relays bytes)."""
    import subprocess
    import sys
    from pathlib import Path

    served = FrontProcess(Listen(0), ('127.0.0.1', 9), (), 1000)
    front.append(served)
    maps = Path(f'/proc/{served.pid}/maps')
    if maps.exists():  # the libraries the running child has loaded
        libraries = maps.read_text()
        assert 'zenoh' not in libraries and 'foxglove' not in libraries
        assert 'numpy' not in libraries

    code = 'import sys, zros.gateway.foxglove.front_process; print(" ".join(sorted(sys.modules)))'
    loaded = subprocess.run(
        [sys.executable, '-c', code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert 'zros.gateway.foxglove.front_process' in loaded
    heavy = [m for m in loaded if m.split('.')[0] in ('zenoh', 'foxglove', 'numpy')]
    assert not heavy
    assert 'zros.gateway.common.watched_topics' not in loaded and 'zros.transport' not in loaded


def test_a_process_that_ends_before_listening_is_an_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from zros.gateway.foxglove import front_process as foxglove_front_process

    child = 'import sys; print("not a report"); sys.exit(3)  # {}'
    monkeypatch.setattr(foxglove_front_process, '_CHILD', child)
    with pytest.raises(GatewayError, match=r'ended before listening \(exit code 3\)'):
        FrontProcess(Listen(0), ('127.0.0.1', 9), (), 1000)


def test_a_process_that_neither_answers_nor_ends_is_killed(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    from zros.gateway.foxglove import front_process as foxglove_front_process

    child = 'import signal; signal.pause()  # {}'  # reads not its stdin, ends only when killed
    monkeypatch.setattr(foxglove_front_process, '_CHILD', child)
    monkeypatch.setattr(foxglove_front_process, 'START_TIMEOUT', 1.0)
    monkeypatch.setattr(foxglove_front_process, 'CLOSE_TIMEOUT', 1.0)
    with (
        caplog.at_level(logging.WARNING, 'zros.gateway'),
        pytest.raises(GatewayError, match='the Foxglove front did not start in 1 s'),
    ):
        FrontProcess(Listen(0), ('127.0.0.1', 9), (), 1000)
    assert 'the Foxglove front did not end in 1 s: killed' in caplog.text


def test_the_process_serves_at_most_max_clients(front: list[Front | FrontProcess]) -> None:
    served = FrontProcess(Listen(0), ('127.0.0.1', 9), (), 1000, max_clients=1)
    front.append(served)
    with socket.create_connection(('127.0.0.1', served.port)):
        # accepted in turn: the first is admitted before the second is looked at
        assert _refused(served.port).startswith(b'HTTP/1.1 503')


def test_a_client_that_trickles_its_upgrade_loses_its_place(
    front: list[Front | FrontProcess], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A byte now and then must not hold a connection (of at most ``max_clients``) for hours:
    the whole upgrade request has the handshake's time, not each read."""
    import time

    from zros.gateway.foxglove import handshake

    monkeypatch.setattr(handshake, 'HANDSHAKE_TIMEOUT', 1.0)
    served = Front(Listen(0), ('127.0.0.1', 9), OriginPolicy(), 1000, max_clients=1)
    front.append(served)
    start = time.monotonic()
    with socket.create_connection(('127.0.0.1', served.port)) as slow:
        slow.settimeout(0.25)  # the pace of its bytes
        for byte in b'GET / HTTP/1.1\r\nHost: x\r\n' * 10:
            try:
                slow.sendall(bytes([byte]))
                if slow.recv(1) == b'':
                    break  # closed by the front
            except TimeoutError:
                continue
            except OSError:
                break
        took = time.monotonic() - start
    assert took < 5.0, f'a trickling client held its connection {took:.1f} s'
    assert wait_for(lambda: len(served.admission) == 0, TIMEOUT)
