"""A destroyed node is freed: nothing keeps it (or its entities) alive, and memory stays flat
over many create/destroy cycles."""

from __future__ import annotations

import gc
import os
import weakref
from collections.abc import Callable
from typing import Any

import pytest

import zros
from zros.node import Node
from zros.testing import spinning, wait_for
from zros.transport import Transport

Fibonacci = 'example_interfaces/action/Fibonacci'
Trigger = 'std_srvs/srv/Trigger'


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module runs on both wire schemes."""
    return str(request.param)


def fibonacci(goal: Any) -> Any:
    goal.publish_feedback(sequence=[0, 1])
    result = goal.server.Result()
    result.sequence = [0, 1, 1]
    return result


def busy_node(
    transport: Transport, wire: str, peer: Node, name: str = 'leaky', destroy: bool = True
) -> weakref.ref[Node]:
    """A node that used everything once (entities, calls, goals, parameters, sim time, an
    async callback, logging), then destroyed (unless not ``destroy``); a weak reference to it."""
    node = Node(name, transport=transport, wire=wire, use_sim_time=True)
    got: list[Any] = []
    sub = node.create_subscription('std_msgs/msg/String', 'chatter', got.append)
    latched = node.create_subscription('std_msgs/msg/String', 'latched', qos='latched')
    pub = node.create_publisher('std_msgs/msg/String', 'chatter')
    node.create_publisher('std_msgs/msg/String', 'latched', qos='latched')
    server = node.create_service(Trigger, 'answer', lambda request, response: response)
    client = node.create_client(Trigger, 'answer')
    node.create_timer(0.01, lambda: got.append('tick'))
    node.create_action_server(Fibonacci, 'fibonacci', fibonacci)
    action = node.create_action_client(Fibonacci, 'fibonacci')
    node.declare_parameter('speed', 1.5)
    node.get_logger().info('hello')

    async def later() -> int:
        return 1

    assert node.run_coroutine(later()).result(10) == 1
    with spinning(node):
        assert pub.wait_for_subscribers(10)
        pub.write(zros.Message('std_msgs/msg/String', data='hi'))
        assert wait_for(lambda: got, 10)
        assert client.wait_for_service(10)
        assert client.call(timeout=10) == server.Response()
        assert client.call_async(timeout=10).result(10) == server.Response()
        assert action.wait_for_server(10)
        handle = action.send_goal(order=2, timeout=10)
        assert list(handle.result(10).sequence) == [0, 1, 1]
    remote = peer.parameter_client(node.fully_qualified_name)
    assert remote.wait_for_node(10)
    remote.set('speed', 2.5, timeout=10)
    assert node.get_parameter('speed') == 2.5
    remote.close()
    latched.take()
    sub.has_new_message()
    node.count_publishers('chatter')
    if destroy:
        node.destroy()
    return weakref.ref(node)


def referrers(obj: object, depth: int = 2) -> str:
    """What still refers to ``obj``, and to those (for the failure message)."""
    lines = []
    for referrer in gc.get_referrers(obj):
        if type(referrer).__name__ == 'frame':
            continue
        lines.append(f'{type(referrer).__name__} {repr(referrer)[:200]}')
        if depth > 1:
            lines += ['    ' + line for line in referrers(referrer, depth - 1).splitlines()]
    return '\n'.join(lines)


def test_a_destroyed_node_is_freed(
    zros_transport: Callable[..., Transport], zros_node: Callable[..., Node], zros_wire: str
) -> None:
    transport = zros_transport()  # shared, and still open after the node is gone
    peer = zros_node('peer')
    node = busy_node(transport, zros_wire, peer)
    assert wait_for(lambda: gc.collect() >= 0 and node() is None, 10), referrers(node())
    # the same for a node whose transport closes it
    closing_transport = zros_transport()
    closing = busy_node(closing_transport, zros_wire, peer, 'closing', destroy=False)
    closing_transport.close()
    assert wait_for(lambda: gc.collect() >= 0 and closing() is None, 10), referrers(closing())


def test_the_default_node_is_freed_after_shutdown(
    zros_router: Any, zros_node: Callable[..., Node], zros_wire: str
) -> None:
    peer = zros_node('peer')
    peer.declare_parameter('speed', 1.0)
    default = zros.init('default', connect=zros_router.endpoint, wire=zros_wire,
                        shared_memory=False, handle_sigint=False)  # fmt: skip
    try:
        zros.Subscriber('chatter', 'std_msgs/msg/String')
        assert zros.param_get('/peer:speed', timeout=10) == 1.0
        ref = weakref.ref(default)
        del default
    finally:
        zros.shutdown()
    assert wait_for(lambda: gc.collect() >= 0 and ref() is None, 10), referrers(ref())


def test_entities_closed_on_a_live_node_are_freed(zros_node: Callable[..., Node]) -> None:
    node = zros_node('owner')
    got: list[Any] = []
    entities: list[Any] = [
        node.create_subscription('std_msgs/msg/String', 'chatter', got.append),
        node.create_subscription('std_msgs/msg/String', 'latched', qos='latched'),
        node.create_publisher('std_msgs/msg/String', 'chatter'),
        node.create_publisher('std_msgs/msg/String', 'latched', qos='latched'),
        node.create_service(Trigger, 'trigger', lambda request, response: response),
        node.create_client(Trigger, 'trigger'),
        node.create_action_server(Fibonacci, 'fibonacci', fibonacci),
        node.create_action_client(Fibonacci, 'fibonacci'),
    ]
    timer = node.create_timer(0.01, lambda: got.append('tick'))
    with spinning(node):
        assert entities[2].wait_for_subscribers(10)
        entities[2].write(zros.Message('std_msgs/msg/String', data='hi'))
        assert entities[5].wait_for_service(10) and entities[5].call(timeout=10)
        assert entities[7].wait_for_server(10)
        assert entities[7].send_goal(order=2, timeout=10).result(10)
        assert wait_for(lambda: 'tick' in got and len(got) > 1, 10)
    timer.cancel()
    refs = [weakref.ref(entity) for entity in [*entities, timer]]
    for entity in entities:
        entity.close()
    del entities, entity, timer  # the loop variable holds the last one
    assert wait_for(lambda: gc.collect() >= 0 and all(r() is None for r in refs), 10), [
        referrers(r()) for r in refs if r() is not None
    ]
    assert node.ok()


def rss() -> int:
    """This process's resident memory in bytes."""
    with open('/proc/self/statm') as statm:
        return int(statm.read().split()[1]) * os.sysconf('SC_PAGE_SIZE')


@pytest.mark.parametrize('zros_wire', ['bridge'])  # the entities are the same on both wires
def test_memory_stays_flat_over_a_thousand_create_destroy_cycles(
    zros_transport: Callable[..., Transport], zros_wire: str
) -> None:
    transport = zros_transport()

    def cycle() -> None:
        node = Node('cycled', transport=transport, wire=zros_wire)
        node.create_subscription('std_msgs/msg/String', 'chatter', lambda m: None)
        node.create_publisher('std_msgs/msg/String', 'chatter')
        node.create_service(Trigger, 'trigger', lambda request, response: response)
        node.create_client(Trigger, 'trigger')
        node.create_timer(1.0, lambda: None)
        node.create_action_server(Fibonacci, 'fibonacci', fibonacci)
        node.create_action_client(Fibonacci, 'fibonacci')
        node.declare_parameter('speed', 1.0)
        node.destroy()

    for _ in range(200):  # warm-up: caches, code, Zenoh's own pools
        cycle()
    gc.collect()
    before = rss()
    for _ in range(1000):
        cycle()
    gc.collect()
    grown = rss() - before
    print(f'RSS {before / 2**20:.1f} MiB -> {(before + grown) / 2**20:.1f} MiB over 1000 cycles')

    def alive() -> int:
        gc.collect()
        return sum(isinstance(o, Node) and o.name == 'cycled' for o in gc.get_objects())

    assert wait_for(lambda: alive() == 0, 10)  # Zenoh's threads let the last one go
    assert grown < 4 * 2**20, f'{grown / 1000:.0f} bytes per cycle'
