"""The node clients of the gateway tests: npm packages in ``node/`` (installed once, ``npm ci``
from the committed lock file) and scripts run by node that speak JSON lines (commands in,
events out): :class:`NodeProcess` is their Python face.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import shutil
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests.support.streams import Drained

NODE_DIR = Path(__file__).with_name('node')
#: set in CI: a missing node or npm fails the tests instead of skipping them
REQUIRED = 'ZROS_TEST_NODE_REQUIRED'
TIMEOUT = 20.0

_install_lock = threading.Lock()


def install(package: str = '@foxglove/ws-protocol') -> str | None:
    """Install the npm packages if ``package`` is missing; None when ready, else why the
    tests cannot run."""
    node, npm = shutil.which('node'), shutil.which('npm')
    if node is None or npm is None:
        return 'node and npm are needed for the tests with JavaScript clients'
    with _install_lock:
        if (NODE_DIR / 'node_modules' / package).is_dir():
            return None
        result = subprocess.run(
            [npm, 'ci', '--no-audit', '--no-fund', '--loglevel=error'],
            cwd=NODE_DIR,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
        if result.returncode != 0:
            return f'npm ci failed in {NODE_DIR}: {result.stderr.strip()[-500:]}'
    return None


def require(package: str = '@foxglove/ws-protocol') -> None:
    """Skip the calling test where the client cannot run (fail instead when ``REQUIRED`` is
    set, as in CI)."""
    import pytest

    reason = install(package)
    if reason is not None:
        if os.environ.get(REQUIRED):
            pytest.fail(reason)
        pytest.skip(reason)


class NodeProcess:
    """A node script speaking JSON lines (commands in, events out); events are kept in order
    and waited for by predicate."""

    def __init__(self, args: list[str]) -> None:
        self.process = subprocess.Popen(
            args,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            bufsize=1,
        )
        self.errors = Drained(self.process.stderr)
        self.events: list[dict[str, Any]] = []
        self._arrived = threading.Condition()
        self._ids = itertools.count(1)
        self._pump = threading.Thread(target=self._read, daemon=True)
        self._pump.start()
        self.wait(lambda e: e['ev'] in ('open', 'error', 'close'))  # commands need an open socket

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            event = json.loads(line)
            with self._arrived:
                self.events.append(event)
                self._arrived.notify_all()
        with self._arrived:
            self.events.append({'ev': 'exit'})
            self._arrived.notify_all()

    def send(self, cmd: str, **args: Any) -> None:
        """Send a command to the client."""
        assert self.process.stdin is not None
        self.process.stdin.write(json.dumps({'cmd': cmd, **args}) + '\n')
        self.process.stdin.flush()

    def wait(
        self, predicate: Callable[[dict[str, Any]], bool], timeout: float = TIMEOUT, start: int = 0
    ) -> dict[str, Any]:
        """The first event from index ``start`` on for which ``predicate`` holds."""
        deadline = time.monotonic() + timeout
        with self._arrived:
            index = start
            while True:
                while index < len(self.events):
                    event = self.events[index]
                    index += 1
                    if predicate(event):
                        return event
                    if event['ev'] == 'exit':
                        raise AssertionError(f'the node client ended: {self.errors.text()}')
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    recent = [str(e)[:200] for e in self.events[-5:]]
                    raise AssertionError(f'no such event within {timeout} s; the last: {recent}')
                self._arrived.wait(remaining)

    def mark(self) -> int:
        """The index of the next event (wait for what comes after an action)."""
        with self._arrived:
            return len(self.events)

    def of(self, kind: str) -> list[dict[str, Any]]:
        """Every event of one kind so far."""
        with self._arrived:
            return [e for e in self.events if e['ev'] == kind]

    def close(self) -> None:
        """Stop the script (its stdin closes; killed if it lingers)."""
        if self.process.poll() is None:
            assert self.process.stdin is not None
            with contextlib.suppress(OSError):
                self.process.stdin.close()
            try:
                self.process.wait(5)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(5)
