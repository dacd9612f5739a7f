"""A TCP proxy on loopback that delays every chunk by a fixed time each way (a WAN in a box).

``tc netem`` is not available on our machines; this delivers each chunk at arrival + delay,
in order, which is what a long link does to a TCP stream. It counts the bytes it relays each
way (``relayed['up']`` towards the target, ``relayed['down']`` back), so with no delay it is
also a meter of what a link carries.

With ``rate`` (bytes per second) each direction is also a bottleneck of that bandwidth: a chunk
leaves it when the chunks before it have, at ``rate``, and arrives ``delay`` later. ``buffer``
(bytes; default the bandwidth-delay product) bounds what waits at the bottleneck: past it the
proxy stops reading, so the sender's TCP sees the back-pressure a real path gives instead of
piling megabytes into loopback socket buffers; the proxy's own sockets then get small buffers
(one read's worth), so that what the path holds is the bottleneck's queue and its delay line.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import threading
import time
from collections.abc import Coroutine
from types import TracebackType


class DelayProxy:
    """Listens on ``127.0.0.1:<free port>`` and forwards to ``target`` (host, port)."""

    def __init__(
        self,
        target: tuple[str, int],
        delay: float,
        *,
        rate: float | None = None,
        buffer: int | None = None,
    ) -> None:
        self.target = target
        self.delay = delay
        self.rate = rate  #: bytes per second each way (None: unlimited)
        if buffer is None and rate is not None:
            buffer = max(int(rate * 2 * delay), 65536)
        self.buffer = buffer  #: bytes that may wait at the bottleneck
        self.port = 0
        self._loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._server: asyncio.Server | None = None
        self._tasks: set[asyncio.Task[None]] = set()
        self.relayed = {'up': 0, 'down': 0}  #: bytes received to relay, each way
        self._thread = threading.Thread(target=self._run, name='delay-proxy', daemon=True)
        self._thread.start()
        if not self._ready.wait(5):
            raise RuntimeError('the delay proxy did not start')

    @property
    def endpoint(self) -> str:
        return f'tcp/127.0.0.1:{self.port}'

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._size(listener)  # before listen(): accepted sockets inherit it
        listener.bind(('127.0.0.1', 0))
        self._server = self._loop.run_until_complete(
            asyncio.start_server(self._accept, sock=listener, limit=self._chunk)
        )
        self.port = self._server.sockets[0].getsockname()[1]
        self._ready.set()
        self._loop.run_forever()

    @property
    def _chunk(self) -> int:
        return 65536 if self.buffer is None else min(65536, max(self.buffer // 8, 4096))

    def _size(self, sock: socket.socket) -> None:
        if self.buffer is not None:  # Linux doubles what it is given
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self._chunk // 2)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self._chunk // 2)

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._size(sock)
        sock.setblocking(False)
        try:
            await self._loop.sock_connect(sock, self.target)
            up_reader, up_writer = await asyncio.open_connection(sock=sock, limit=self._chunk)
        except OSError:
            sock.close()
            writer.close()
            return
        for side in (writer, up_writer):
            side.transport.set_write_buffer_limits(high=self._chunk)
        for task in (self._pump(reader, up_writer, 'up'), self._pump(up_reader, writer, 'down')):
            self._track(task)

    def _track(self, coroutine: Coroutine[None, None, None]) -> asyncio.Task[None]:
        # every task is kept until it ends, so that close() can cancel and await all of them
        # (a task left pending when the loop stops is reported at exit as destroyed)
        task = asyncio.ensure_future(coroutine)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)
        return task

    async def _pump(
        self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter, way: str
    ) -> None:
        """Copy ``reader`` to ``writer``, each chunk ``delay`` seconds after it arrived; the
        writer (this direction's socket) is closed however the pump ends."""
        queue: asyncio.Queue[tuple[float, bytes]] = asyncio.Queue()
        rate, buffer = self.rate, self.buffer
        out = 0.0  #: when the bottleneck is done with what it was given so far

        async def deliver() -> None:
            while True:
                due, chunk = await queue.get()
                if not chunk:
                    return
                wait = due - time.monotonic()
                if wait > 0:
                    await asyncio.sleep(wait)
                writer.write(chunk)
                await writer.drain()

        sender = self._track(deliver())
        try:
            with contextlib.suppress(ConnectionError, OSError):
                while chunk := await reader.read(self._chunk):
                    self.relayed[way] += len(chunk)
                    now = time.monotonic()
                    if rate is None:
                        queue.put_nowait((now + self.delay, chunk))
                        continue
                    out = max(out, now) + len(chunk) / rate
                    queue.put_nowait((out + self.delay, chunk))
                    if buffer is not None and (out - now) * rate > buffer:
                        await asyncio.sleep(out - now - buffer / rate)  # the bottleneck is full
            queue.put_nowait((0.0, b''))
            with contextlib.suppress(ConnectionError, OSError):
                await sender
        finally:
            sender.cancel()
            writer.close()
            with contextlib.suppress(ConnectionError, OSError, asyncio.CancelledError):
                await writer.wait_closed()

    def close(self) -> None:
        """Stop accepting and cut every relayed connection."""

        async def stop() -> None:
            if self._server is not None:
                self._server.close()
                await self._server.wait_closed()
            tasks = list(self._tasks)
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)

        if self._loop.is_running():
            asyncio.run_coroutine_threadsafe(stop(), self._loop).result(5)
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(5)
        if not self._thread.is_alive() and not self._loop.is_closed():
            self._loop.close()

    def __enter__(self) -> DelayProxy:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()
