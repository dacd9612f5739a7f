"""pytest fixtures for testing code that uses zros, installed as a pytest plugin.

* ``zros_router``: a Zenoh router inside the test process on ``tcp/127.0.0.1:<free port>``,
  multicast scouting and shared memory off.
* ``zros_transport``: a factory of sessions connected to that router (each like a process of
  its own).
* ``zros_node``: a factory of nodes, each on a session of its own unless ``transport=`` is given.
* ``zros_wire``: the wire scheme of those nodes, the default one (``'bridge'``); override it
  in a test module to run its tests on every scheme zros speaks::

      from zros.wire import SCHEMES

      @pytest.fixture(params=list(SCHEMES))  # 'bridge', 'rmw_zenoh'
      def zros_wire(request):
          return request.param

Everything is closed at teardown. ``with spinning(node):`` spins a node (say, a service server)
on a background thread; :func:`peak_memory` runs a command and samples its memory (Linux).
Wait for conditions with :func:`wait_for`, never with sleeps::

    def test_chatter(zros_node):
        talker, listener = zros_node('talker'), zros_node('listener')
        sub = listener.create_subscription('std_msgs/msg/String', 'chatter')
        pub = talker.create_publisher('std_msgs/msg/String', 'chatter')
        assert pub.wait_for_subscribers()
        pub.write(zros.Message('std_msgs/msg/String', data='hi'))
        assert wait_for(sub.has_new_message)
"""

from __future__ import annotations

import contextlib
import subprocess
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Protocol

import pytest

from zros.node import Node
from zros.transport import Router, Transport, start_router
from zros.wire import DEFAULT_WIRE, session_config

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from zros.node.settings import NodeOptions
    from zros.transport.config import SessionOptions


def wait_for(condition: Callable[[], object], timeout: float = 5.0) -> bool:
    """Poll ``condition()`` until it is true or ``timeout`` seconds pass; returns the outcome."""
    deadline = time.monotonic() + timeout
    delay = 0.0002
    while True:
        if condition():
            return True
        if time.monotonic() >= deadline:
            return bool(condition())
        time.sleep(delay)
        delay = min(delay * 2, 0.01)


@dataclass(frozen=True)
class PeakMemory:
    """What :func:`peak_memory` saw of a process: the largest resident anonymous memory and
    file-mapped memory (bytes, each at its own peak), its exit code and output; when asked,
    the peak anonymous memory of its child processes (summed at each sample) and of the
    process and its children together."""

    anonymous: int
    file: int
    returncode: int
    stdout: str
    stderr: str
    children_anonymous: int = 0
    total_anonymous: int = 0


def _resident(pid: int) -> tuple[int, int]:
    """RssAnon and RssFile of a process, in bytes."""
    found = {}
    for line in Path(f'/proc/{pid}/status').read_text().splitlines():
        name, _, value = line.partition(':')
        if name in ('RssAnon', 'RssFile'):
            found[name] = int(value.split()[0]) * 1024
    return found.get('RssAnon', 0), found.get('RssFile', 0)


def child_processes(pid: int) -> list[int]:
    """The process ids of a process's children (Linux: ``/proc/PID/task/*/children``, or the
    parent of every process where the kernel has no such files; none elsewhere)."""
    tasks = list(Path(f'/proc/{pid}/task').glob('*/children'))
    if not tasks:
        return [p for p, parent in _parents() if parent == pid]
    found: list[int] = []
    for task in tasks:
        with contextlib.suppress(OSError):  # the thread ended meanwhile
            found.extend(int(child) for child in task.read_text().split())
    return found


def _parents() -> Iterator[tuple[int, int]]:
    """(process id, parent id) of every process (from ``/proc/*/stat``)."""
    for stat in Path('/proc').glob('[0-9]*/stat'):
        try:
            fields = stat.read_text().rpartition(')')[2].split()
        except OSError:  # ended meanwhile
            continue
        yield int(stat.parent.name), int(fields[1])


def _children_anonymous(pid: int) -> int:
    total = 0
    for child in child_processes(pid):
        with contextlib.suppress(OSError, ValueError):  # ended since it was listed
            total += _resident(child)[0]
    return total


def peak_memory(
    argv: Sequence[str],
    *,
    env: Mapping[str, str] | None = None,
    timeout: float = 600.0,
    interval: float = 0.001,
    children: bool = False,
) -> PeakMemory:
    """Run ``argv`` and sample its ``/proc/PID/status`` every ``interval`` seconds until it
    ends (Linux only): a peak shorter than an interval can be missed. With ``children``, its
    child processes are sampled too. Raises ``subprocess.TimeoutExpired`` (the process
    killed) after ``timeout`` seconds."""
    anonymous = file = below = total = 0
    deadline = time.monotonic() + timeout
    output = {'stdout': '', 'stderr': ''}
    with subprocess.Popen(
        list(argv),
        env=None if env is None else dict(env),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as process:

        def drain(name: str, stream: IO[str]) -> None:  # a full pipe would block the process
            output[name] = stream.read()

        assert process.stdout is not None and process.stderr is not None  # both piped
        readers = [
            threading.Thread(target=drain, args=('stdout', process.stdout), daemon=True),
            threading.Thread(target=drain, args=('stderr', process.stderr), daemon=True),
        ]
        for reader in readers:
            reader.start()
        while process.poll() is None:
            try:
                anon, mapped = _resident(process.pid)
            except (OSError, ValueError):  # ended between poll and read
                break
            anonymous, file = max(anonymous, anon), max(file, mapped)
            if children:
                theirs = _children_anonymous(process.pid)
                below, total = max(below, theirs), max(total, anon + theirs)
            if time.monotonic() > deadline:
                process.kill()
                process.wait()
                raise subprocess.TimeoutExpired(list(argv), timeout)
            time.sleep(interval)
        process.wait()
        for reader in readers:
            reader.join()
    return PeakMemory(
        anonymous, file, process.returncode, output['stdout'], output['stderr'], below, total
    )


@contextlib.contextmanager
def spinning(*nodes: Node) -> Iterator[None]:
    """Spin ``nodes`` on background threads inside the ``with`` block (servers in tests)."""
    stop = threading.Event()

    def run(node: Node) -> None:
        while not stop.is_set() and node.ok():
            node.spin_once(timeout=0.05)

    threads = [
        threading.Thread(target=run, args=(node,), name=f'spin {node.name}', daemon=True)
        for node in nodes
    ]
    for thread in threads:
        thread.start()
    try:
        yield
    finally:
        stop.set()
        for node in nodes:
            node.context.executor.wake()
        for thread in threads:
            thread.join(5)


@pytest.fixture
def zros_router() -> Iterator[Router]:
    """A router inside the test process (``zros_router.endpoint`` is where to connect)."""
    router = start_router(shared_memory=False)
    try:
        yield router
    finally:
        router.close()


class MakeTransport(Protocol):
    """The ``zros_transport`` fixture: ``make(**settings)``."""

    def __call__(self, **settings: Unpack[SessionOptions]) -> Transport: ...


class MakeNode(Protocol):
    """The ``zros_node`` fixture: ``make(name, namespace='/', **options)``."""

    def __call__(
        self, name: str = 'test_node', namespace: str = '/', **options: Unpack[NodeOptions]
    ) -> Node: ...


@pytest.fixture
def zros_transport(zros_router: Router) -> Iterator[MakeTransport]:
    """``make(**settings)`` opens a client session to ``zros_router``."""
    opened: list[Transport] = []

    def make(**settings: Unpack[SessionOptions]) -> Transport:
        settings.setdefault('shared_memory', False)
        transport = Transport(session_config(zros_router.endpoint, **settings))
        opened.append(transport)
        return transport

    try:
        yield make
    finally:
        for transport in reversed(opened):
            transport.close()


@pytest.fixture
def zros_wire() -> str:
    """The wire scheme of the nodes ``zros_node`` makes (override it to parametrise)."""
    return DEFAULT_WIRE


@pytest.fixture
def zros_node(zros_transport: MakeTransport, zros_wire: str) -> Iterator[MakeNode]:
    """``make(name, namespace='/', **options)``: a node on a session of its own."""
    made: list[Node] = []

    def make(name: str = 'test_node', namespace: str = '/', **options: Unpack[NodeOptions]) -> Node:
        options.setdefault('wire', zros_wire)
        if 'transport' not in options:
            options['transport'] = zros_transport()
        node = Node(name, namespace, **options)
        made.append(node)
        return node

    try:
        yield make
    finally:
        for node in reversed(made):
            node.destroy()
