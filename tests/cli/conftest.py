"""Run the real ``zros`` console script against a router inside the test process."""

from __future__ import annotations

import contextlib
import fcntl
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from tests.support.streams import Drained
from zros.transport import Router

ZROS = shutil.which('zros', path=str(Path(sys.executable).parent))
TIMEOUT = 60.0


@dataclass
class Running:
    """A ``zros`` command still running; its output lines arrive in ``lines``."""

    process: subprocess.Popen[str]
    errors: Drained  #: what it writes on stderr
    lines: queue.Queue[str | None] = field(default_factory=queue.Queue)
    seen: list[str] = field(default_factory=list)

    def wait_line(self, predicate: Callable[[str], bool], timeout: float = TIMEOUT) -> str:
        """The first new line for which ``predicate`` holds; fails on timeout or exit."""
        deadline = time.monotonic() + timeout
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise AssertionError(f'no such line within {timeout} s; output: {self.seen}')
            try:
                line = self.lines.get(timeout=remaining)
            except queue.Empty:
                continue
            if line is None:
                error = self.errors.text()
                raise AssertionError(f'the command ended; output: {self.seen}; stderr: {error}')
            self.seen.append(line)
            if predicate(line):
                return line

    def finish(self, timeout: float = TIMEOUT) -> tuple[int, str]:
        """Wait for the end; exit code and the output lines not read yet. A command still
        running after ``timeout`` is aborted, and the failure shows where its threads were."""
        try:
            code = self.process.wait(timeout)
        except subprocess.TimeoutExpired:
            self.process.send_signal(signal.SIGABRT)  # faulthandler prints every thread's stack
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.process.wait(10)
            self.process.kill()
            raise AssertionError(
                f'{self.process.args!r} did not end within {timeout} s; output: {self.seen}; '
                f'stderr and stacks:\n{self.errors.text()[-8000:]}'
            ) from None
        rest: list[str] = []
        while (line := self.lines.get(timeout=timeout)) is not None:
            rest.append(line)
        return code, '\n'.join(rest)


@dataclass
class Cli:
    """``run(...)`` a command to its end, or ``start(...)`` one to talk to while it runs."""

    endpoint: str
    started: list[Running] = field(default_factory=list)

    def env(self, extra: dict[str, str] | None = None) -> dict[str, str]:
        # faulthandler: a command that hangs shows its threads' stacks when aborted
        env = dict(
            os.environ, ZROS_CONNECT=self.endpoint, PYTHONUNBUFFERED='1', PYTHONFAULTHANDLER='1'
        )
        env.pop('ZENOH_CONFIG', None)
        return {**env, **(extra or {})}

    def run(
        self, *args: str, timeout: float = TIMEOUT, env: dict[str, str] | None = None
    ) -> subprocess.CompletedProcess[str]:
        """Run ``zros ARGS`` to its end (``env``: variables to add or override)."""
        assert ZROS is not None
        return subprocess.run(
            [ZROS, *args],
            capture_output=True,
            stdin=subprocess.DEVNULL,
            text=True,
            timeout=timeout,
            env=self.env(env),
            check=False,
        )

    def start(self, *args: str, env: dict[str, str] | None = None) -> Running:
        """Start ``zros ARGS`` in the background (``env``: variables to add or override)."""
        assert ZROS is not None
        process = subprocess.Popen(
            [ZROS, *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            env=self.env(env),
        )
        running = Running(process, Drained(process.stderr))

        def pump() -> None:
            assert process.stdout is not None
            for line in process.stdout:
                running.lines.put(line.rstrip('\n'))
            running.lines.put(None)

        threading.Thread(target=pump, daemon=True).start()
        self.started.append(running)
        return running

    def first_line_then_close(self, *args: str) -> tuple[str, int, str]:
        """Start a command writing into a small pipe (one page), read its first line, close the
        pipe as ``| head -1`` does, and wait for the end. Returns the line, the exit code and
        what the command wrote on stderr."""
        assert ZROS is not None
        read_end, write_end = os.pipe()
        # one page: a command that writes more than that blocks until the reader goes away
        fcntl.fcntl(write_end, fcntl.F_SETPIPE_SZ, 4096)
        process = subprocess.Popen(
            [ZROS, *args],
            stdout=write_end,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            text=True,
            # as from a shell: stdout to a pipe is block-buffered (unbuffered, Python drops the
            # rest of a write the pipe cut short without an error)
            env={k: v for k, v in self.env().items() if k != 'PYTHONUNBUFFERED'},
        )
        os.close(write_end)
        line = b''
        try:
            while not line.endswith(b'\n'):
                byte = os.read(read_end, 1)  # unbuffered: the rest stays in the pipe
                if not byte:
                    break
                line += byte
        finally:
            os.close(read_end)
        try:
            _, stderr = process.communicate(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            process.kill()
            raise
        return line.decode(), process.returncode, stderr


@contextmanager
def publishing(node: Any, publisher: Any, message: Any, hz: float = 50.0) -> Iterator[None]:
    """``publisher`` (of ``node``) writes ``message`` at ``hz`` on a thread until the block ends."""
    stop = threading.Event()

    def talk() -> None:
        rate = node.create_rate(hz)
        while not stop.is_set():
            publisher.write(message)
            rate.sleep()

    thread = threading.Thread(target=talk, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(5)


@pytest.fixture
def cli(zros_router: Router) -> Iterator[Cli]:
    """The ``zros`` command connected to ``zros_router``."""
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    commands = Cli(zros_router.endpoint)
    yield commands
    for running in commands.started:
        if running.process.poll() is None:
            running.process.kill()
            running.process.wait(10)
