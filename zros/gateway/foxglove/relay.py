"""One connection of the Foxglove front, in one thread: the upgrade, then the relay between the
client and the SDK's server, and the client's queue bounded in bytes (how:
:mod:`~zros.gateway.foxglove.front`)."""

from __future__ import annotations

import collections
import contextlib
import fcntl
import logging
import os
import selectors
import socket
import ssl
from collections.abc import Sequence
from typing import TYPE_CHECKING, Protocol

from zros.gateway.common.drop_notice import DropNotices
from zros.gateway.foxglove.handshake import HANDSHAKE_TIMEOUT, read_upgrade
from zros.gateway.foxglove.ws_frames import droppable, end_of_frame, status_frame, whole_frames

if TYPE_CHECKING:
    from zros.gateway.common.origins import OriginPolicy

_log = logging.getLogger('zros.gateway')

#: bytes read from the server at once (frames larger than this get a buffer of their own)
_CHUNK = 1024 * 1024
#: client bytes waiting for the server before the front stops reading the client
_CLIENT_BACKLOG = 1024 * 1024
#: fcntl's pipe size commands (Linux)
_F_SETPIPE_SZ = 1031
_F_GETPIPE_SZ = 1032
_SPLICE_FLAGS = getattr(os, 'SPLICE_F_MOVE', 0) | getattr(os, 'SPLICE_F_NONBLOCK', 0)


class Door(Protocol):
    """The front a connection came through (:class:`~zros.gateway.foxglove.front.Front`): its
    settings, and the counters of all its connections."""

    tls: ssl.SSLContext | None
    server_address: tuple[str, int]
    origins: OriginPolicy
    client_buffer: int
    closing: socket.socket  #: readable once the front closes
    dropped: int
    reported: int


class Connection:
    """One client: the handshake, then the relay (see the module docstring)."""

    def __init__(self, front: Door, client: socket.socket, name: str) -> None:
        self.front = front
        self.client = client
        self.name = name
        self.upstream: socket.socket | None = None
        # the server's frames on their way to the client (allocated once upgraded: a
        # connection that never finishes its handshake holds no megabyte)
        self._rx = bytearray()
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
        self._notices = DropNotices()
        # the client's bytes on their way to the server
        self._to_server = bytearray()
        self._upstream_done = False

    # --- the handshake ---------------------------------------------------------------------

    def _handshake(self) -> bool:
        """The upgrade (:mod:`~zros.gateway.foxglove.handshake`), relayed to the server; False
        when the connection ends here."""
        front = self.front
        self.client.settimeout(HANDSHAKE_TIMEOUT)
        if front.tls is not None:
            self.client = front.tls.wrap_socket(self.client, server_side=True)
        upgrade = read_upgrade(self.client, front.origins)
        if upgrade is None:
            return False
        self.upstream = socket.create_connection(front.server_address, timeout=HANDSHAKE_TIMEOUT)
        self.upstream.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        after = upgrade.relay(self.upstream, self.client)
        if after is None:
            return False
        self._rx = bytearray(_CHUNK)
        self._rx_view = memoryview(self._rx)
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
            selector.register(self.front.closing, selectors.EVENT_READ)
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
                    if key.fileobj is self.front.closing:
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
        position, frame_end = whole_frames(rx, start, end)
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
            if self.front.tls is not None or not hasattr(os, 'splice'):
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
                begun = end_of_frame(frames, 0, len(frames))
                while begun <= sent:
                    begun = end_of_frame(frames, begun, len(frames))
                self._sending = memoryview(bytes(frames[sent:begun]))
                frames = frames[begun:]
        split: list[memoryview | bytes] = []
        position = 0
        while position < len(frames):
            frame_end = end_of_frame(frames, position, len(frames))
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
            if droppable(frame):
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
        if self._notices.due(self._dropped) is None:
            return
        self.front.reported += 1
        text = (
            f'client {self.name} does not read fast enough: its oldest messages are being '
            f'dropped (each client has room for {bound} bytes; {self._dropped} dropped so far)'
        )
        _log.warning('%s', text)
        status = status_frame(text)
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
