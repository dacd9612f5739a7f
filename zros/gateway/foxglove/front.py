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

``zros foxglove`` runs the front in a process of its own, off the gateway's GIL
(:mod:`zros.gateway.foxglove.front_process`): this module imports nothing of Zenoh or the SDK.
"""

from __future__ import annotations

import collections
import contextlib
import fcntl
import json
import logging
import os
import secrets
import selectors
import socket
import ssl
import threading
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

from zros.gateway.common.errors import GatewayError

if TYPE_CHECKING:
    from zros.gateway.common.listen import Listen
    from zros.gateway.common.origins import OriginPolicy

_log = logging.getLogger('zros.gateway')

#: the subprotocol the SDK's server speaks
SDK_SUBPROTOCOL = 'foxglove.sdk.v1'
#: the subprotocols the front accepts (the same protocol under two names)
SUBPROTOCOLS = ('foxglove.websocket.v1', SDK_SUBPROTOCOL)
#: bytes queued for one client before its oldest messages are dropped
CLIENT_BUFFER = 32 * 1024**2
#: seconds between two warnings to (and log lines about) one slow client
REPORT_PERIOD = 1.0
#: the longest HTTP request or response head accepted
MAX_HEAD = 16 * 1024
#: seconds a client has for its TLS handshake and upgrade request
HANDSHAKE_TIMEOUT = 10.0
#: bytes read from the server at once (frames larger than this get a buffer of their own)
_CHUNK = 1024 * 1024
#: client bytes waiting for the server before the front stops reading the client
_CLIENT_BACKLOG = 1024 * 1024
#: buffers given to one sendmsg
_GATHER = 256
#: fcntl's pipe size commands (Linux)
_F_SETPIPE_SZ = 1031
_F_GETPIPE_SZ = 1032
_SPLICE_FLAGS = getattr(os, 'SPLICE_F_MOVE', 0) | getattr(os, 'SPLICE_F_NONBLOCK', 0)
_OP_BINARY = 0x2
_MESSAGE_DATA = 1  # the Foxglove protocol's binary opcode of a message


class Front:
    """Listens where ``listen`` says and relays each connection to the SDK's server at
    ``upstream`` (see the module docstring); ``port`` is the port it got."""

    def __init__(
        self,
        listen: Listen,
        upstream: tuple[str, int],
        origins: OriginPolicy,
        client_buffer: int,
    ) -> None:
        self._upstream = upstream
        self.origins = origins
        self.client_buffer = client_buffer
        self._tls = listen.ssl_context()
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
        self._stop_r, self._stop_w = socket.socketpair()
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
            _Connection(self, client, name).run()
        except Exception:  # one client's failure never reaches the others
            _log.debug('the connection of %s failed', name, exc_info=True)
        finally:
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
        self._stop_r.close()
        self._stop_w.close()


class _Head:
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


def _read_head(sock: socket.socket) -> tuple[bytes, bytes] | None:
    """An HTTP head read from ``sock`` (blocking) and the bytes after it; None when the peer
    closed or sent more than MAX_HEAD without ending it."""
    data = b''
    while b'\r\n\r\n' not in data:
        if len(data) > MAX_HEAD:
            return None
        chunk = sock.recv(4096)
        if not chunk:
            return None
        data += chunk
    head, _, rest = data.partition(b'\r\n\r\n')
    return head, rest


def _status_frame(text: str) -> bytes:
    """A Foxglove warning status as a server's text frame."""
    payload = json.dumps({'op': 'status', 'level': 1, 'message': text, 'id': 'zros.slow'}).encode()
    size = len(payload)
    if size < 126:
        return bytes((0x81, size)) + payload
    return bytes((0x81, 126)) + size.to_bytes(2, 'big') + payload


def _frame_end(data: bytearray | memoryview, start: int, end: int) -> int:
    """Where the frame at ``start`` ends; -1 when ``data[start:end]`` does not hold its
    header yet."""
    if end - start < 2:
        return -1
    size = data[start + 1] & 0x7F
    if size < 126:
        return start + 2 + size
    if size == 126:
        if end - start < 4:
            return -1
        return start + 4 + int.from_bytes(data[start + 2 : start + 4], 'big')
    if end - start < 10:
        return -1
    return start + 10 + int.from_bytes(data[start + 2 : start + 10], 'big')


def _whole_frames(data: bytearray, start: int, end: int) -> tuple[int, int]:
    """Where the whole frames from ``start`` on end in ``data[:end]``, and where the frame
    after them ends (-1: its header is not whole yet).

    A run of frames of one size (a topic of fixed-size messages) is skipped at C speed: from
    a frame's start, the frames after it have the same size as long as their headers repeat
    the same bytes at the same stride (a 2 or 4 byte header: length under 64 KiB)."""
    position = start
    while True:
        frame_end = _frame_end(data, position, end)
        if frame_end < 0 or frame_end > end:
            return position, frame_end
        stride = frame_end - position
        size = data[position + 1] & 0x7F
        count = (end - position) // stride
        if size == 127 or count < 4:
            position = frame_end
            continue
        header = 2 if size < 126 else 4
        stop = position + count * stride
        same = count
        for offset in range(header):
            column = data[position + offset : stop : stride]
            same = min(same, count - len(column.lstrip(column[:1])))
        position += same * stride


def _droppable(frame: bytearray | bytes | memoryview) -> bool:
    """Whether a whole frame is message data (binary, final, Foxglove opcode 1)."""
    first = frame[0]
    if first != 0x80 | _OP_BINARY:
        return False
    size = frame[1] & 0x7F
    offset = 2 if size < 126 else 4 if size == 126 else 10
    return len(frame) > offset and frame[offset] == _MESSAGE_DATA


class _Connection:
    """One client: the handshake, then the relay (see the module docstring)."""

    def __init__(self, front: Front, client: socket.socket, name: str) -> None:
        self.front = front
        self.client = client
        self.name = name
        self.upstream: socket.socket | None = None
        # the server's frames on their way to the client
        self._rx = bytearray(_CHUNK)
        self._rx_view = memoryview(self._rx)
        self._start = 0  # the first byte of rx not yet handled
        self._end = 0  # the end of what rx holds
        self._big: memoryview | None = None  # a frame larger than rx, being received
        self._big_fill = 0
        self._rest = False  # _big is the rest of a frame the client has begun
        # a large frame moving from socket to socket in the kernel, while the client keeps up
        self._pipe: tuple[int, int] | None = None
        self._pipe_size = 0
        self._piped = 0  # bytes in the pipe, for the client
        self._stream_left = 0  # bytes of the frame still to move into the pipe
        # big frames' buffers, for the next ones: reused, not given back to malloc, whose
        # arenas (one per thread that allocates) each keep megabytes of what is freed
        self._pool: list[bytearray] = []
        self._pooled = 0
        self._sending: memoryview | None = None  # what the client is being sent now
        self._kept: collections.deque[memoryview | bytes] = collections.deque()  # before _queue
        self._queue: collections.deque[memoryview | bytes] = collections.deque()
        self._queued = 0  # bytes in _kept and _queue
        self._dropped = 0
        self._dropped_bytes = 0
        self._last_report = -REPORT_PERIOD
        # the client's bytes on their way to the server
        self._to_server = bytearray()
        self._upstream_done = False

    # --- the handshake ---------------------------------------------------------------------

    def _handshake(self) -> bool:
        """The upgrade, relayed with its subprotocol named as each side expects; False when
        the connection ends here."""
        front = self.front
        self.client.settimeout(HANDSHAKE_TIMEOUT)
        if front._tls is not None:
            self.client = front._tls.wrap_socket(self.client, server_side=True)
        read = _read_head(self.client)
        if read is None:
            return False
        request, rest = _Head(read[0]), read[1]
        origin = request.first_value('origin')
        if origin is not None and not front.origins.accepts(origin):
            body = front.origins.refuse(origin).encode()
            self.client.sendall(
                b'HTTP/1.1 403 Forbidden\r\nContent-Type: text/plain; charset=utf-8\r\n'
                b'Content-Length: %d\r\nConnection: close\r\n\r\n%b' % (len(body), body)
            )
            return False
        offered = request.values('sec-websocket-protocol')
        chosen = next((p for p in offered if p in SUBPROTOCOLS), None)
        if chosen is not None:
            request.replace('Sec-WebSocket-Protocol', SDK_SUBPROTOCOL)
        self.upstream = socket.create_connection(front._upstream, timeout=HANDSHAKE_TIMEOUT)
        self.upstream.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.upstream.sendall(request.encode() + rest)
        answer = _read_head(self.upstream)
        if answer is None:
            return False
        response, after = _Head(answer[0]), answer[1]
        if chosen is not None and response.first_value('sec-websocket-protocol') is not None:
            response.replace('Sec-WebSocket-Protocol', chosen)
        self.client.sendall(response.encode())
        self._rx[: len(after)] = after
        self._end = len(after)
        return True

    def run(self) -> None:
        try:
            if self._handshake():
                self.client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._relay()
        except (OSError, ValueError) as exc:  # the peer went away, or TLS failed
            _log.debug('connection of %s: %s', self.name, exc)
        finally:
            if self._dropped:
                _log.warning(
                    'client %s left; %d of its messages (%d bytes) were dropped',
                    self.name,
                    self._dropped,
                    self._dropped_bytes,
                )
            self.client.close()
            if self.upstream is not None:
                self.upstream.close()
            if self._pipe is not None:
                os.close(self._pipe[0])
                os.close(self._pipe[1])

    # --- the relay -------------------------------------------------------------------------

    def _relay(self) -> None:
        assert self.upstream is not None
        client, upstream = self.client, self.upstream
        client.setblocking(False)
        upstream.setblocking(False)
        selector = selectors.DefaultSelector()
        try:
            selector.register(self.front._stop_r, selectors.EVENT_READ)
            selector.register(upstream, selectors.EVENT_READ)
            selector.register(client, selectors.EVENT_READ)
            wanted = {upstream: selectors.EVENT_READ, client: selectors.EVENT_READ}
            self._split()  # frames that came with the answer to the upgrade
            self._from_server()
            while True:
                want_client = (
                    selectors.EVENT_READ if len(self._to_server) < _CLIENT_BACKLOG else 0
                ) | (selectors.EVENT_WRITE if self._pending() else 0)
                want_upstream = (0 if self._upstream_done else selectors.EVENT_READ) | (
                    selectors.EVENT_WRITE if self._to_server else 0
                )
                for sock, want in ((client, want_client), (upstream, want_upstream)):
                    if wanted[sock] != want:
                        if wanted[sock]:
                            selector.unregister(sock)
                        if want:
                            selector.register(sock, want)
                        wanted[sock] = want
                if self._upstream_done and not self._pending():
                    return  # the server closed, and the client has all it sent
                if not wanted[client] and not wanted[upstream]:
                    return
                for key, events in selector.select():
                    if key.fileobj is self.front._stop_r:
                        return
                    if key.fileobj is upstream:
                        if events & selectors.EVENT_WRITE and not self._to_upstream():
                            return
                        if events & selectors.EVENT_READ:
                            self._from_server()
                    else:
                        if events & selectors.EVENT_WRITE:
                            self._to_client()
                        if events & selectors.EVENT_READ and not self._from_client():
                            return
        finally:
            selector.close()

    def _from_client(self) -> bool:
        """Read what the client sent, for the server; False when it closed."""
        while len(self._to_server) < _CLIENT_BACKLOG:
            try:
                data = self.client.recv(65536)
            except (BlockingIOError, ssl.SSLWantReadError, ssl.SSLWantWriteError):
                break
            if not data:
                return False
            self._to_server += data
        return self._to_upstream()

    def _to_upstream(self) -> bool:
        assert self.upstream is not None
        while self._to_server:
            try:
                sent = self.upstream.send(self._to_server)
            except BlockingIOError:
                return True
            except OSError:
                return False
            del self._to_server[:sent]
        return True

    def _receive(self, into: memoryview) -> int:
        """Bytes read from the server into ``into``; 0 when none came (or it closed)."""
        assert self.upstream is not None
        try:
            got = self.upstream.recv_into(into)
        except BlockingIOError:
            return 0
        if not got:
            self._upstream_done = True
        return got

    def _from_server(self) -> None:
        """Read what the server sent and pass its whole frames on."""
        while True:
            if self._stream_left:
                if not self._stream():
                    return
                continue
            if self._big is not None:
                got = self._receive(self._big[self._big_fill :])
                if not got:
                    return
                self._big_fill += got
                if self._big_fill == len(self._big):
                    frame, self._big = self._big, None
                    if self._rest:  # sent next, before any other frame
                        self._rest = False
                        self._sending = frame
                        self._to_client()
                    else:
                        self._frames([frame])
                continue
            if self._end == len(self._rx):  # make room: move the partial frame first
                left = self._end - self._start
                self._rx[:left] = self._rx[self._start : self._end]
                self._start, self._end = 0, left
            got = self._receive(self._rx_view[self._end :])
            if not got:
                return
            self._end += got
            self._split()

    def _split(self) -> None:
        """Pass on the whole frames rx holds; a frame too large for rx gets a buffer."""
        rx, start, end = self._rx, self._start, self._end
        position, frame_end = _whole_frames(rx, start, end)
        if position > start:
            self._run(self._rx_view[start:position])
        self._start = position
        if frame_end > position + _CHUNK:  # too large for rx
            self._start = self._end = 0
            head = self._rx_view[position:end]
            if not self._pending() and self._can_splice():
                # the client keeps up: the frame goes from socket to socket in the kernel
                sent = self._send_now(head)
                if sent == len(head):
                    self._stream_left = frame_end - end
                    return
                self._begin_rest(head[sent:], frame_end - end)
                return
            self._begin_big(frame_end - position, head)
        elif self._start == self._end:
            self._start = self._end = 0

    def _take(self, size: int) -> memoryview:
        """A buffer of ``size`` bytes (a kept one, if one is large enough)."""
        for index, kept in enumerate(self._pool):
            if len(kept) >= size:
                del self._pool[index]
                self._pooled -= len(kept)
                return memoryview(kept)[:size]
        return memoryview(bytearray(size))[:size]

    def _begin_big(self, size: int, head: memoryview) -> None:
        """Receive a frame of ``size`` bytes, ``head`` its start, into a buffer of its own."""
        self._big = self._take(size)
        self._big_fill = len(head)
        self._big[: self._big_fill] = head

    def _begin_rest(self, head: memoryview, left: int) -> None:
        """Receive the unsent rest of a begun frame (``head`` and ``left`` more bytes)."""
        self._begin_big(len(head) + left, head)
        self._rest = True

    def _can_splice(self) -> bool:
        """Whether frames can move in the kernel (plain sockets, Linux): opens the pipe."""
        if self._pipe is None:
            if self.front._tls is not None or not hasattr(os, 'splice'):
                return False
            self._pipe = os.pipe2(os.O_NONBLOCK | os.O_CLOEXEC)
            with contextlib.suppress(OSError):  # a smaller pipe where the system says so
                fcntl.fcntl(self._pipe[1], _F_SETPIPE_SZ, _CHUNK)
            self._pipe_size = fcntl.fcntl(self._pipe[1], _F_GETPIPE_SZ)
        return True

    def _send_now(self, data: memoryview) -> int:
        try:
            return self.client.send(data)
        except (BlockingIOError, ssl.SSLWantWriteError, ssl.SSLWantReadError):
            return 0

    def _stream(self) -> bool:
        """Move the streamed frame on (server to pipe to client); False when the server has
        nothing more now. A client that stops taking it gets its rest from a buffer."""
        assert self._pipe is not None and self.upstream is not None
        moved = -1
        room = self._pipe_size - self._piped
        if room > 0:
            try:
                moved = os.splice(
                    self.upstream.fileno(),
                    self._pipe[1],
                    min(room, self._stream_left),
                    flags=_SPLICE_FLAGS,
                )
            except BlockingIOError:
                moved = -1
            if moved == 0:
                self._upstream_done = True
                return False
            if moved > 0:
                self._piped += moved
                self._stream_left -= moved
        self._to_client()
        if self._stream_left and self._piped >= self._pipe_size:  # the client stopped taking
            self._begin_rest(memoryview(b''), self._stream_left)
            self._stream_left = 0
            return True
        return moved > 0

    def _run(self, frames: memoryview) -> None:
        """Whole frames from rx: sent at once while the client keeps up, else queued."""
        if not self._pending():
            sent = self._send_now(frames)
            if sent == len(frames):
                return
            if sent:  # the rest of a frame the client has begun
                begun = _frame_end(frames, 0, len(frames))
                while begun <= sent:
                    begun = _frame_end(frames, begun, len(frames))
                self._sending = memoryview(bytes(frames[sent:begun]))
                frames = frames[begun:]
        split: list[memoryview | bytes] = []
        position = 0
        while position < len(frames):
            frame_end = _frame_end(frames, position, len(frames))
            split.append(bytes(frames[position:frame_end]))
            position = frame_end
        self._frames(split)

    def _frames(self, frames: Sequence[memoryview | bytes]) -> None:
        """Queue whole frames for the client (a lone big frame is sent at once if it can)."""
        if len(frames) == 1 and not self._pending():
            self._sending = memoryview(frames[0])
            self._to_client()
            return
        for frame in frames:
            self._queue.append(frame)
            self._queued += len(frame)
        if self._queued > self.front.client_buffer:
            self._drop()

    def _drop(self) -> None:
        """Drop the oldest message frames until the queue fits its bound; tell the client."""
        bound = self.front.client_buffer
        dropped = dropped_bytes = 0
        while self._queued > bound and self._queue:
            frame = self._queue.popleft()
            self._queued -= len(frame)
            if _droppable(frame):
                dropped += 1
                dropped_bytes += len(frame)
                self._recycle(frame)
            else:
                self._kept.append(frame)
                self._queued += len(frame)
                if not self._queue:
                    break
        if not dropped:
            return
        self._dropped += dropped
        self._dropped_bytes += dropped_bytes
        self.front.dropped += dropped
        now = time.monotonic()
        if now - self._last_report < REPORT_PERIOD:
            return
        self._last_report = now
        self.front.reported += 1
        text = (
            f'client {self.name} does not read fast enough: its oldest messages are being '
            f'dropped (each client has room for {bound} bytes; {self._dropped} dropped so far)'
        )
        _log.warning('%s', text)
        status = _status_frame(text)
        self._kept.append(status)
        self._queued += len(status)

    def _recycle(self, frame: memoryview | bytes) -> None:
        """Keep a big frame's buffer for the next big frames (at most half the client's
        bound in all; the smallest go first)."""
        buffer = frame.obj if isinstance(frame, memoryview) else None
        if not isinstance(buffer, bytearray) or buffer is self._rx:
            return
        self._pool.append(buffer)
        self._pooled += len(buffer)
        self._pool.sort(key=len, reverse=True)
        while self._pooled > self.front.client_buffer // 2 and self._pool:
            self._pooled -= len(self._pool.pop())

    def _pending(self) -> bool:
        return self._piped > 0 or self._sending is not None or bool(self._kept) or bool(self._queue)

    def _next(self) -> memoryview | None:
        for queue in (self._kept, self._queue):
            if queue:
                frame = queue.popleft()
                self._queued -= len(frame)
                return frame if isinstance(frame, memoryview) else memoryview(frame)
        return None

    def _to_client(self) -> None:
        """Send the client what it can take now."""
        if self._piped:
            assert self._pipe is not None
            try:
                self._piped -= os.splice(
                    self._pipe[0], self.client.fileno(), self._piped, flags=_SPLICE_FLAGS
                )
            except BlockingIOError:
                return
            if self._piped:
                return
        if self._stream_left or self._rest:
            return  # the rest of the frame begun comes first
        while True:
            if self._sending is None:
                self._sending = self._next()
                if self._sending is None:
                    return
            sending = self._sending
            try:
                sent = self.client.send(sending)
            except (BlockingIOError, ssl.SSLWantWriteError, ssl.SSLWantReadError):
                return
            if sent < len(sending):
                self._sending = sending[sent:]
                return
            self._sending = None
            self._recycle(sending)


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
