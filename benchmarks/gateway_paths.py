"""The ways a message takes in ``benchmarks/gateway.py``, each driven turn by turn.

Every path is up at once, on a topic of its own (``/bench/data<tag>``), and the driver gives
each a turn of messages in order, so the machine's drift (larger here than the differences
measured) falls on all alike:

  * :class:`ZrosPath`: a zros publisher and a zros subscriber (``transport.py``'s roles);
  * :class:`ClientPath`: a server that prints its URL as ``zros foxglove`` does (the gateway,
    or a role of ``gateway.py``), the ``@foxglove/ws-protocol`` node client subscribed to the
    topic (or, ``lean``, ``counter.js`` beside it: node's ``ws`` counting message frames), and a
    zros publisher, unless the server sends the messages itself. The CPU of the server's child
    (``zros foxglove``'s front) is counted apart.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
sys.path[:0] = [str(HERE.parent), str(HERE.parents[1])]

from transport_roles import (  # noqa: E402
    busiest_thread,
    cpu_seconds,
    end_roles,
    publish_turn,
    read_line,
    send_turn,
    spawn_role,
    thread_seconds,
    wait_ready,
)

from tests.gateway.foxglove.client import SCRIPT, FoxgloveClient  # noqa: E402
from tests.gateway.node_process import NODE_DIR  # noqa: E402
from zros.testing import child_processes  # noqa: E402

#: the client that counts message frames and parses nothing else of them
LEAN = NODE_DIR / 'counter.js'

#: how long a turn may go without a new message before it counts as ended
STALL = 20.0


def topic(tag: str) -> str:
    """The topic of the path tagged ``tag``."""
    return f'/bench/data{tag}'


def gateway_command(endpoint: str) -> list[str]:
    """``zros foxglove`` connected to ``endpoint``, on a free port, with an outbox large
    enough that the benchmark loses nothing."""
    zros = shutil.which('zros', path=str(Path(sys.executable).parent))
    assert zros is not None, 'the zros command is not installed beside this Python'
    return [zros, 'foxglove', '--connect', endpoint, '--port', '0', '--no-sim-time',
            '--message-backlog', '1000000', '--client-buffer', '16GiB']  # fmt: skip


def start_server(command: list[str]) -> tuple[subprocess.Popen[str], str]:
    """Start a server that prints ``Foxglove: <url>`` first (its stdin a pipe); the process
    and the URL."""
    server = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    assert server.stdout is not None
    line = server.stdout.readline()
    if not line.startswith('Foxglove: '):
        raise RuntimeError(f'{command[:2]} did not start: {line!r}')
    return server, line.split()[1]


def _publisher(kind: str, endpoint: str, tag: str) -> subprocess.Popen[str]:
    extra = ['--kind', kind, '--tag', tag, '--turns']
    return spawn_role('publish', 'zros', endpoint, extra, False, stdin=subprocess.PIPE)


class ZrosPath:
    """A zros publisher and a zros subscriber with a callback."""

    def __init__(self, kind: str, endpoint: str, tag: str, turn: int) -> None:
        extra = ['--kind', kind, '--tag', tag, '--turns', '--count', str(turn)]
        self.subscriber = spawn_role('subscribe', 'zros', endpoint, extra, False)
        wait_ready(self.subscriber)
        self.publisher = _publisher(kind, endpoint, tag)
        wait_ready(self.publisher)

    def turn(self, count: int) -> dict[str, Any]:
        """``count`` messages through (the subscriber counts them as its turn)."""
        return publish_turn(self.publisher, self.subscriber, count)

    def close(self) -> None:
        end_roles([self.publisher, self.subscriber])


class ClientPath:
    """A server process printing ``Foxglove: <url>``, the node client subscribed to the path's
    topic, and a zros publisher (``publish``), or the server sending itself (its stdin)."""

    def __init__(
        self, command: list[str], kind: str, endpoint: str, tag: str, *, publish: bool,
        lean: bool = False, protocol: str | None = None,
    ) -> None:  # fmt: skip
        self.server, url = start_server(command)
        # zros foxglove's front runs in a child of its own: its CPU is the gateway's too
        self.front = next(iter(child_processes(self.server.pid)), None)
        self.client = FoxgloveClient(url, script=LEAN if lean else SCRIPT, protocol=protocol)
        self.publisher = _publisher(kind, endpoint, tag) if publish else None
        # the topic shows once the publisher is up; the publisher waits for the tap this makes
        self.subscription = self.client.subscribe(topic(tag), 60, quiet=True)
        if self.publisher is not None:
            wait_ready(self.publisher)

    def turn(self, count: int) -> dict[str, Any]:
        """``count`` messages through, counted by the client from the turn's first."""
        client, key = self.client, str(self.subscription)
        client.send('quiet', subscriptionId=self.subscription)  # counts anew
        assert client.stats()[key]['count'] == 0
        pids = {'cpu': self.server.pid, 'cpu_client': self.client.process.pid}
        if self.front is not None:
            pids['cpu_front'] = self.front
        cpu = {name: cpu_seconds(pid) for name, pid in pids.items()}
        threads = {name: thread_seconds(pid) for name, pid in pids.items()}
        router = time.process_time()
        send_turn(self.publisher or self.server, count)
        progress, last = -1, time.monotonic()
        while True:
            found = dict(client.stats()[key])
            if found['count'] >= count or time.monotonic() - last > STALL:
                break
            if found['count'] != progress:
                progress, last = found['count'], time.monotonic()
            time.sleep(0.02)
        result: dict[str, Any] = {
            'received': found['count'], 'expected': count,
            'rate': (found['count'] - 1) / max(found['seconds'], 1e-9),
            'size': found['bytes'] / max(found['count'], 1),
            'cpu_router': time.process_time() - router,
        }  # fmt: skip
        for name, pid in pids.items():
            result[name] = cpu_seconds(pid) - cpu[name]
            result[f'{name}_thread'] = busiest_thread(threads[name], thread_seconds(pid))
        if self.publisher is not None:
            result['cpu_publisher'] = read_line(self.publisher)['cpu']
        return result

    def close(self) -> None:
        self.client.close()
        end_roles([p for p in (self.publisher, self.server) if p is not None])
