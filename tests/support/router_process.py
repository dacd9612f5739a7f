"""A router in a process of its own, which a test can kill (by its PID) and start again."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import zros
from zros.actions import ServerGoalHandle
from zros.cdr.message import Message
from zros.transport import Transport, TransportConfig

ROUTER = """
import sys, threading
from zros.transport import start_router
router = start_router(sys.argv[1])
print(router.endpoint, flush=True)
threading.Event().wait()
"""


def free_endpoint() -> str:
    """A loopback TCP endpoint nothing listens on now."""
    with socket.socket() as probe:
        probe.bind(('127.0.0.1', 0))
        return f'tcp/127.0.0.1:{probe.getsockname()[1]}'


class RouterProcess:
    """A router process on ``endpoint``: ``start()``, ``kill()``, ``start()`` again."""

    def __init__(self, endpoint: str) -> None:
        self.endpoint = endpoint
        self.process: subprocess.Popen[str] | None = None

    def start(self) -> None:
        self.process = subprocess.Popen(
            [sys.executable, '-c', ROUTER, self.endpoint], stdout=subprocess.PIPE, text=True
        )
        assert self.process.stdout is not None
        assert self.process.stdout.readline().strip() == self.endpoint

    def kill(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait(10)


@contextmanager
def router_running() -> Iterator[RouterProcess]:
    """A router process on a free loopback port, killed at the end."""
    router = RouterProcess(free_endpoint())
    router.start()
    try:
        yield router
    finally:
        router.kill()


TRIGGER = 'std_srvs/srv/Trigger'
FIB = 'example_interfaces/action/Fibonacci'
#: what a call would wait without the link check: the test asserts the error comes well before
CALL_TIMEOUT = 30.0


class Rig:
    """A server node and a caller node, each on a session of its own to a killable router."""

    def __init__(self, router: RouterProcess) -> None:
        self.router = router
        self.transports = [
            Transport(TransportConfig.create(connect=router.endpoint, shared_memory=False))
            for _ in range(2)
        ]
        self.server = zros.Node('server', transport=self.transports[0])
        self.caller = zros.Node('caller', transport=self.transports[1])
        self.holding = threading.Event()  #: the server holds a request or goal
        self.release = threading.Event()
        self.server.create_service(TRIGGER, 'slow', self._slow)
        self.server.create_action_server(FIB, 'fib', self._execute)
        threading.Thread(target=self.server.spin, daemon=True).start()
        self.killed = 0.0

    def _slow(self, request: Message, response: Message) -> Message:
        self.holding.set()
        self.release.wait(CALL_TIMEOUT)
        return response

    def _execute(self, goal: ServerGoalHandle) -> Message:
        self.holding.set()
        self.release.wait(CALL_TIMEOUT)
        return goal.server.Result()

    def kill_router_when_held(self) -> None:
        """Kill the router (by its PID) as soon as the server holds the request."""

        def kill() -> None:
            assert self.holding.wait(CALL_TIMEOUT)
            self.killed = time.monotonic()
            self.router.kill()

        threading.Thread(target=kill, daemon=True).start()

    def close(self) -> None:
        self.release.set()
        for transport in self.transports:
            transport.close()


@contextmanager
def rig_running() -> Iterator[Rig]:
    """A :class:`Rig` on a router process of its own, closed (and the router killed) at the end."""
    with router_running() as router:
        rig = Rig(router)
        try:
            yield rig
        finally:
            rig.close()
