"""Python scripts run as processes of their own, connected to a test's router."""

from __future__ import annotations

import os
import queue
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

from tests.support.streams import Drained
from zros.transport import Router


def launch(code: str, router: Router, **extra_env: str) -> subprocess.Popen[str]:
    """Run ``code`` (dedented) in a new interpreter with ``ZROS_CONNECT`` set to ``router``."""
    env = {**os.environ, 'ZROS_CONNECT': router.endpoint, **extra_env}
    return subprocess.Popen(
        [sys.executable, '-c', textwrap.dedent(code)],
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


class Script:
    """A launched script whose output lines are read as they come, each with its arrival time."""

    def __init__(self, code: str, router: Router, **extra_env: str) -> None:
        self.process = launch(code, router, **extra_env)
        self._errors = Drained(self.process.stderr)
        self._lines: queue.Queue[tuple[float, str] | None] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self._lines.put((time.monotonic(), line.rstrip('\n')))
        self._lines.put(None)

    def expect(self, prefix: str, timeout: float) -> tuple[float, str]:
        """The next line starting with ``prefix`` and when it came; AssertionError (with the
        script's stderr) when it does not come within ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while True:
            try:
                item = self._lines.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                item = None
            if item is None:
                raise AssertionError(f'no line {prefix!r} within {timeout} s: {self.stop()}')
            if item[1].startswith(prefix):
                return item

    def send(self, line: str) -> None:
        """Write a line to the script's stdin."""
        assert self.process.stdin is not None
        self.process.stdin.write(line + '\n')
        self.process.stdin.flush()

    def stop(self) -> str:
        """Kill the script if it still runs; its stderr."""
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(30)
        return self._errors.text()


def sleeping(pid: int) -> bool:
    """Whether the main thread of process ``pid`` sleeps (blocked in a wait, not running): a
    signal sent now lands in that wait."""
    stat = Path(f'/proc/{pid}/stat').read_text()
    return stat.rsplit(')', 1)[1].split()[0] == 'S'
