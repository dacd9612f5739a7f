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
on a background thread. Wait for conditions with :func:`wait_for`, never with sleeps::

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
import threading
import time
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Protocol

import pytest

from zros.node import Node
from zros.transport import Router, Transport, TransportConfig, start_router
from zros.wire import DEFAULT_WIRE

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from zros.node.settings import NodeOptions
    from zros.transport.config import TransportOptions


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

    def __call__(self, **settings: Unpack[TransportOptions]) -> Transport: ...


class MakeNode(Protocol):
    """The ``zros_node`` fixture: ``make(name, namespace='/', **options)``."""

    def __call__(
        self, name: str = 'test_node', namespace: str = '/', **options: Unpack[NodeOptions]
    ) -> Node: ...


@pytest.fixture
def zros_transport(zros_router: Router) -> Iterator[MakeTransport]:
    """``make(**settings)`` opens a client session to ``zros_router``."""
    opened: list[Transport] = []

    def make(**settings: Unpack[TransportOptions]) -> Transport:
        settings.setdefault('shared_memory', False)
        transport = Transport(TransportConfig.create(connect=zros_router.endpoint, **settings))
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
