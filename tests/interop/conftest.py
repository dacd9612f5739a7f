"""Fixtures of the interop tests: a bridge (stand-in or real), rclpy workers, zros nodes.

* ``interop_bridge`` (session): :class:`~tests.interop.rig.BridgeUnderTest` with namespace ``/``
  (or the real bridge named by ``ZROS_INTEROP_BRIDGE``).
* ``bot1_bridge`` (module): a bridge with namespace ``/bot1``.
* ``ros``: the session's rclpy worker; what a test creates on it is destroyed after the test.
* ``zros_nodes``: ``make(bridge, name='zros_node')`` -> a zros node on a session of its own.
* ``unique_topic``: ``unique_topic('chatter')`` -> ``/it_chatter_<n>`` (no reuse between tests).
* ``interop``: all of the above for the ``/`` bridge, as one :class:`Interop`.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import pytest

from tests.interop import rig

_topics = itertools.count(1)


def _skip_unless_possible() -> None:
    if rig.external_bridge() is None:
        reason = rig.local_skip_reason()
        if reason is not None:
            pytest.skip(reason)


@pytest.fixture(scope='session')
def interop_bridge() -> Iterator[rig.BridgeUnderTest]:
    _skip_unless_possible()
    with rig.bridge_under_test('/') as bridge:
        yield bridge


@pytest.fixture(scope='module')
def bot1_bridge() -> Iterator[rig.BridgeUnderTest]:
    _skip_unless_possible()
    if rig.external_bridge() is not None:
        with rig.bridge_under_test() as bridge:
            if bridge.namespace != '/bot1':
                pytest.skip(
                    f'the real bridge has namespace {bridge.namespace}; run one with -n /bot1 '
                    f'and {rig.ENV_BRIDGE_NAMESPACE}=/bot1 for this test'
                )
            yield bridge
        return
    with rig.bridge_under_test('/bot1') as bridge:
        yield bridge


@pytest.fixture
def standin(interop_bridge: rig.BridgeUnderTest) -> rig.LocalRig:
    """The local rig; skips against a real bridge (whose parser aborts on malformed tokens)."""
    if interop_bridge.rig is None:
        pytest.skip('needs the stand-in (a real bridge aborts on malformed tokens)')
    return interop_bridge.rig


class TrackedWorker:
    """A worker whose publishers and subscriptions made by one test go away after it."""

    def __init__(self, worker: rig.RosWorker) -> None:
        self.worker = worker
        self.made: list[str] = []

    def publisher(self, *args: Any, **kwargs: Any) -> str:
        name = self.worker.publisher(*args, **kwargs)
        self.made.append(name)
        return name

    def subscription(self, *args: Any, **kwargs: Any) -> str:
        name = self.worker.subscription(*args, **kwargs)
        self.made.append(name)
        return name

    def service(self, *args: Any, **kwargs: Any) -> str:
        name = self.worker.service(*args, **kwargs)
        self.made.append(name)
        return name

    def action_server(self, *args: Any, **kwargs: Any) -> str:
        name = self.worker.action_server(*args, **kwargs)
        self.made.append(name)
        return name

    def destroy(self, name: str) -> None:
        self.worker.destroy(name)
        self.made.remove(name)

    def __getattr__(self, item: str) -> Any:
        return getattr(self.worker, item)

    def cleanup(self) -> None:
        for name in reversed(self.made):
            self.worker.destroy(name)
        self.made.clear()


@pytest.fixture(scope='session')
def _session_worker(interop_bridge: rig.BridgeUnderTest) -> Iterator[rig.RosWorker]:
    worker = interop_bridge.new_worker()
    yield worker
    worker.close()


@pytest.fixture
def ros(_session_worker: rig.RosWorker) -> Iterator[TrackedWorker]:
    tracked = TrackedWorker(_session_worker)
    yield tracked
    tracked.cleanup()


@functools.cache
def _registry() -> Any:
    from tests.interop.rclpy_support import make_registry

    return make_registry()


@pytest.fixture
def zros_nodes() -> Iterator[Callable[..., Any]]:
    """``make(bridge, name='zros_node', **node_options)``: a zros node on its own session."""
    import zros
    from zros.transport import Transport, TransportConfig

    registry = _registry()
    made: list[tuple[Any, Any]] = []

    def make(bridge: rig.BridgeUnderTest, name: str = 'zros_node', **options: Any) -> Any:
        transport = Transport(TransportConfig.create(connect=bridge.endpoint, shared_memory=False))
        options.setdefault('bridge_namespace', bridge.namespace)
        options.setdefault('registry', registry)
        options.setdefault('enable_rosout', False)
        # Token-counting tests expect only the entities they create.
        options.setdefault('start_parameter_services', False)
        node = zros.Node(name, options.pop('namespace', '/'), transport=transport, **options)
        made.append((node, transport))
        return node

    yield make
    for node, transport in reversed(made):
        node.destroy()
        transport.close()


@pytest.fixture
def unique_topic() -> Callable[[str], str]:
    return lambda stem: f'/it_{stem}_{next(_topics)}'


@dataclass
class Interop:
    """One test's view of the ``/`` bridge: rclpy worker, zros node factory, fresh topic names."""

    bridge: rig.BridgeUnderTest
    ros: TrackedWorker
    make_node: Callable[..., Any]
    unique_topic: Callable[[str], str]

    def node(self, name: str = 'zros_node', **options: Any) -> Any:
        """A zros node connected to the bridge, on a session of its own."""
        return self.make_node(self.bridge, name, **options)

    def topic(self, stem: str) -> str:
        return self.unique_topic(stem)

    def standin_log(self) -> str:
        """The end of the stand-in's log, for a failure's message (a real bridge: nothing)."""
        local = self.bridge.rig
        return '(a real bridge: no log here)' if local is None else local.log_tail()


@pytest.fixture
def interop(
    interop_bridge: rig.BridgeUnderTest,
    ros: TrackedWorker,
    zros_nodes: Callable[..., Any],
    unique_topic: Callable[[str], str],
) -> Iterator[Interop]:
    yield Interop(interop_bridge, ros, zros_nodes, unique_topic)
    local = interop_bridge.rig
    if local is not None and not local.standin_alive():
        pytest.fail(f'the bridge stand-in died; its log ends with:\n{local.log_tail()}')
