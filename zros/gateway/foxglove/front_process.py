"""The Foxglove front in a process of its own, off the gateway's GIL.

In the gateway's process the front's threads cost it about a fifth more CPU per message and
took the GIL from the Zenoh delivery thread that hands messages to the SDK (figures in
benchmarks/). :class:`FrontProcess` runs :class:`~zros.gateway.foxglove.front.Front` in a
child (``python -c`` running :func:`main`) that imports neither Zenoh, nor the SDK, nor numpy.

The parent writes the settings as one JSON line on the child's stdin (never in its argv: a
command line is readable by every user of the machine) and keeps stdin open: the child ends
when it reads EOF, so a gateway that dies, even by SIGKILL, never leaves its port held. The
child answers on its stdout, one JSON object per line: ``{"ready": port}`` or
``{"error": message}`` once, then ``{"counters": [dropped, reported]}`` when they change (at
most five times a second) and ``{"log": [level, text]}`` for each record of its
``zros.gateway`` logger, which the parent logs as its own.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import signal
import subprocess
import sys
import threading
from typing import IO

from zros.gateway.common.errors import GatewayError
from zros.gateway.common.heap import keep_large_blocks
from zros.gateway.common.limits import MAX_CLIENTS
from zros.gateway.common.listen import Listen
from zros.gateway.common.origins import OriginPolicy
from zros.gateway.foxglove.front import Front

_log = logging.getLogger('zros.gateway')

#: seconds the child has to start listening, and to end once told
START_TIMEOUT = 60.0
CLOSE_TIMEOUT = 10.0
#: seconds between two looks at the child's counters
COUNTER_PERIOD = 0.2
#: what the child runs: ``main`` of this module, found where this ``zros`` is (not where the
#: child's working directory or PYTHONPATH would find one)
_CHILD = 'import sys; sys.path.insert(0, sys.argv[1]); from {} import main; main()'


class FrontProcess:
    """A :class:`~zros.gateway.foxglove.front.Front` listening where ``listen`` says, in a
    child process, relaying to the SDK's server at ``upstream`` at most ``max_clients``
    connections at once; browsers from ``allow_origins`` are accepted (see
    :class:`~zros.gateway.common.origins.OriginPolicy`). GatewayError when it cannot listen."""

    def __init__(
        self,
        listen: Listen,
        upstream: tuple[str, int],
        allow_origins: tuple[str, ...],
        client_buffer: int,
        max_clients: int = MAX_CLIENTS,
    ) -> None:
        self.port = 0
        self.dropped = 0  #: message frames dropped for slow clients, all clients together
        self.reported = 0  #: warnings sent to slow clients
        self._error: str | None = None
        self._answered = threading.Event()
        root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        self._process = subprocess.Popen(
            [sys.executable, '-c', _CHILD.format(__name__), root],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        assert self._process.stdin is not None and self._process.stdout is not None
        self._stdin: IO[bytes] = self._process.stdin
        self._reader = threading.Thread(
            target=self._read,
            args=(self._process.stdout,),
            name='zros foxglove front reader',
            daemon=True,
        )
        self._reader.start()
        settings = {
            'port': listen.port,
            'address': listen.address,
            'tls_cert': None if listen.tls_cert is None else os.fspath(listen.tls_cert),
            'tls_key': None if listen.tls_key is None else os.fspath(listen.tls_key),
            'what': listen.what,
            'upstream': list(upstream),
            'allow_origins': list(allow_origins),
            'client_buffer': client_buffer,
            'max_clients': max_clients,
            'log_level': _log.getEffectiveLevel(),
        }
        try:
            self._stdin.write(json.dumps(settings).encode() + b'\n')
            self._stdin.flush()
        except OSError:
            pass  # it ended already: said below
        if not self._answered.wait(START_TIMEOUT):
            self._error = f'the Foxglove front did not start in {START_TIMEOUT:g} s'
        if self._error is not None or not self.port:
            error = self._error
            self.close()
            if error is None:
                error = (
                    'the Foxglove front process ended before listening '
                    f'(exit code {self._process.returncode})'
                )
            raise GatewayError(error)

    def _read(self, stdout: IO[bytes]) -> None:
        """Take the child's lines until it ends."""
        try:
            for line in stdout:
                try:
                    report = json.loads(line)
                except ValueError:
                    continue
                if 'log' in report:
                    level, text = report['log']
                    _log.log(int(level), '%s', text)
                elif 'counters' in report:
                    self.dropped, self.reported = (int(n) for n in report['counters'])
                elif 'ready' in report:
                    self.port = int(report['ready'])
                    self._answered.set()
                elif 'error' in report:
                    self._error = str(report['error'])
                    self._answered.set()
        finally:
            self._answered.set()
            stdout.close()

    @property
    def pid(self) -> int:
        """The child's process id."""
        return self._process.pid

    def close(self) -> None:
        """End the child: EOF on its stdin, then SIGKILL if it has not ended in time."""
        with contextlib.suppress(OSError):
            self._stdin.close()
        try:
            self._process.wait(CLOSE_TIMEOUT)
        except subprocess.TimeoutExpired:
            _log.warning('the Foxglove front did not end in %g s: killed', CLOSE_TIMEOUT)
            self._process.kill()
            self._process.wait()
        self._reader.join(CLOSE_TIMEOUT)


# --- the child ------------------------------------------------------------------------------


class _Reports:
    """The child's stdout: one JSON object per line, from any thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._out = sys.stdout.buffer

    def send(self, **report: object) -> None:
        line = json.dumps(report).encode() + b'\n'
        with self._lock, contextlib.suppress(OSError):  # the parent is gone: stdin says so
            self._out.write(line)
            self._out.flush()


class _Forward(logging.Handler):
    """Sends each log record to the parent."""

    def __init__(self, reports: _Reports) -> None:
        super().__init__()
        self.reports = reports
        self.setFormatter(logging.Formatter('%(message)s'))

    def emit(self, record: logging.LogRecord) -> None:
        self.reports.send(log=[record.levelno, self.format(record)])


def main() -> None:
    """The child: settings from stdin, then the front until stdin ends."""
    # Ctrl-C reaches the whole process group; the parent ends the child when it is done
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    reports = _Reports()
    settings = json.loads(sys.stdin.buffer.readline())
    log = logging.getLogger('zros.gateway')
    log.addHandler(_Forward(reports))
    log.setLevel(settings['log_level'])
    log.propagate = False
    keep_large_blocks()  # this process relays big messages: reuse their buffers
    listen = Listen(
        settings['port'],
        settings['address'],
        settings['tls_cert'],
        settings['tls_key'],
        settings['what'],
    )
    try:
        front = Front(
            listen,
            (settings['upstream'][0], settings['upstream'][1]),
            OriginPolicy(settings['allow_origins']),
            settings['client_buffer'],
            settings['max_clients'],
        )
    except GatewayError as exc:
        reports.send(error=str(exc))
        sys.exit(1)
    reports.send(ready=front.port)
    ended = threading.Event()

    def counters() -> None:
        last = (0, 0)
        while not ended.wait(COUNTER_PERIOD):
            now = (front.dropped, front.reported)
            if now != last:
                reports.send(counters=now)
                last = now

    counting = threading.Thread(target=counters, name='zros foxglove front counters')
    counting.start()
    while sys.stdin.buffer.read(4096):
        pass
    front.close()
    ended.set()
    counting.join()
    reports.send(counters=(front.dropped, front.reported))
