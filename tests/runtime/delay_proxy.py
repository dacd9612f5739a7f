"""A TCP proxy on loopback that delays every chunk by a fixed time each way (a WAN in a box).

``tc netem`` is not available on our machines; this delivers each chunk at arrival + delay,
in order, which is what a long link does to a TCP stream. It counts the bytes it relays each
way (``relayed['up']`` towards the target, ``relayed['down']`` back), so with no delay it is
also a meter of what a link carries.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import Coroutine
from types import TracebackType


class DelayProxy:
    """Listens on ``127.0.0.1:<free port>`` and forwards to ``target`` (host, port)."""

    def __init__(self, target: tuple[str, int], delay: float) -> None:
        self.target = target
        self.delay = delay
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
        self._server = self._loop.run_until_complete(
            asyncio.start_server(self._accept, '127.0.0.1', 0)
        )
        self.port = self._server.sockets[0].getsockname()[1]
        self._ready.set()
        self._loop.run_forever()

    async def _accept(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            up_reader, up_writer = await asyncio.open_connection(*self.target)
        except OSError:
            writer.close()
            return
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
                while chunk := await reader.read(65536):
                    self.relayed[way] += len(chunk)
                    queue.put_nowait((time.monotonic() + self.delay, chunk))
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
