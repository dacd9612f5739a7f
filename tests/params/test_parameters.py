"""Parameters over the network: a node's services, a remote client, events, the rosR calls."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from zenoh import ZError

import zros
from zros.node import Node
from zros.params import (
    NodeNotFoundError,
    ParameterError,
    ParameterEvent,
    ParameterNotDeclaredError,
    ParameterTimeoutError,
    ParameterType,
    SetResult,
    subscribe_parameter_events,
)
from zros.testing import spinning, wait_for
from zros.transport import Router


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module that makes nodes runs on both wire schemes."""
    return str(request.param)


@pytest.fixture
def driver(zros_node: Callable[..., Node]) -> Node:
    node = zros_node('driver', '/robot')
    node.declare_parameter('speed', 0.5, floating_point_range=(0.0, 2.0, 0.0))
    node.declare_parameter('wheels.count', 4, read_only=True)
    node.declare_parameter('name', 'driver', description='what to call it')
    return node


def test_another_node_reads_and_sets_them(driver: Node, zros_node: Callable[..., Node]) -> None:
    remote = zros_node('tool').parameter_client('/robot/driver')
    assert remote.wait_for_node()
    assert remote.list_parameters() == ['name', 'speed', 'use_sim_time', 'wheels.count']
    assert remote.get_parameters(['speed', 'wheels.count', 'ghost']) == {
        'speed': 0.5,
        'wheels.count': 4,
        'ghost': None,
    }
    assert remote.get_parameter_types(['speed', 'ghost']) == {
        'speed': ParameterType.DOUBLE,
        'ghost': ParameterType.NOT_SET,
    }
    descriptor = remote.describe_parameters(['name'])['name']
    assert descriptor.description == 'what to call it' and descriptor.type is ParameterType.STRING
    results = remote.set_parameters({'speed': 1.5, 'wheels.count': 6, 'name': 7})
    assert [r.successful for r in results] == [True, False, False]
    assert 'read-only' in results[1].reason and 'Wrong parameter type' in results[2].reason
    assert driver.get_parameter('speed') == 1.5  # answered without the driver spinning
    assert remote.set_parameters_atomically({'speed': 1.0, 'wheels.count': 5}) == SetResult(
        False, "parameter 'wheels.count' cannot be set because it is read-only"
    )
    assert driver.get_parameter('speed') == 1.5
    with pytest.raises(ParameterError, match="doesn't comply with floating point range"):
        remote.set('speed', 3.0)


def test_set_callbacks_run_where_the_node_spins(
    driver: Node, zros_node: Callable[..., Node]
) -> None:
    threads: list[threading.Thread] = []

    def veto(parameters: list[Any]) -> Any:
        threads.append(threading.current_thread())
        return all(p.value != 1.25 for p in parameters), 'not 1.25'

    driver.add_on_set_parameters_callback(veto)
    remote = zros_node('tool').parameter_client('/robot/driver')
    assert remote.wait_for_node()
    assert remote.get('speed') == 0.5  # reads still answer without a spin
    with spinning(driver):
        remote.set('speed', 1.0)
        with pytest.raises(ParameterError, match=r'not 1\.25'):
            remote.set('speed', 1.25)
    assert driver.get_parameter('speed') == 1.0
    assert threads and all(t.name == 'spin driver' for t in threads)


def test_pre_and_post_set_callbacks_run_where_the_node_spins(
    driver: Node, zros_node: Callable[..., Node]
) -> None:
    """A network set goes through rclpy's pre-set, on-set and post-set callbacks, on the
    node's spin thread (a user callback never runs on Zenoh's)."""
    threads: list[str] = []

    def pre(parameters: list[Any]) -> list[Any]:
        threads.append(threading.current_thread().name)
        return [zros.Parameter(p.name, value=p.value * 2) for p in parameters]

    def post(parameters: list[Any]) -> None:
        threads.append(threading.current_thread().name)

    driver.add_pre_set_parameters_callback(pre)
    driver.add_post_set_parameters_callback(post)
    remote = zros_node('tool').parameter_client('/robot/driver')
    assert remote.wait_for_node()
    with spinning(driver):
        remote.set('speed', 0.2)
    assert driver.get_parameter('speed') == 0.4  # what the pre-set callback made of it
    assert threads == ['spin driver', 'spin driver']


def test_a_change_holds_when_its_event_cannot_go_out(
    driver: Node, monkeypatch: pytest.MonkeyPatch
) -> None:
    refused: list[Any] = []

    def refuse(message: Any) -> None:  # the session is closing
        refused.append(message)
        raise ZError('session closed')

    monkeypatch.setattr(driver._parameter_server._events, 'write', refuse)  # type: ignore[union-attr]
    driver.set_parameter('speed', 1.5)
    assert driver.get_parameter('speed') == 1.5 and len(refused) == 1


def test_parameter_events(driver: Node, zros_node: Callable[..., Node]) -> None:
    monitor = zros_node('monitor')
    events: list[ParameterEvent] = []
    sub = subscribe_parameter_events(monitor, events.append, node_name='/robot/driver')
    assert wait_for(lambda: driver._parameter_server._events.has_subscribers)  # type: ignore[union-attr]
    # matched is not yet reachable: on rmw_zenoh's peers the token can come before the route.
    # Probe (speed below 1) until an event arrives; the probes are then left out.
    probes = iter(range(1, 10_000))

    def probed() -> bool:
        driver.set_parameter('speed', next(probes) / 10_000)
        monitor.spin_once(0.05)
        return bool(events)

    def probe(event: ParameterEvent) -> bool:
        speed = event.changed.get('speed')
        return isinstance(speed, float) and speed < 1

    assert wait_for(probed)
    driver.set_parameter('speed', 1.0)
    driver.declare_parameter('fresh', [1, 2])
    driver.undeclare_parameter('fresh')

    def told() -> list[ParameterEvent]:
        return [event for event in events if not probe(event)]

    assert wait_for(lambda: monitor.spin_once(0.05) >= 0 and len(told()) == 3)
    changed, new, deleted = told()
    assert changed.changed == {'speed': 1.0} and changed.node == '/robot/driver'
    assert new.new == {'fresh': [1, 2]} and deleted.deleted == ['fresh']
    assert abs((changed.stamp - driver.now()).seconds) < 5
    sub.close()


def test_errors_of_a_remote_client(zros_node: Callable[..., Node]) -> None:
    tool = zros_node('tool')
    with pytest.raises(NodeNotFoundError, match='no node /nobody serves parameters'):
        tool.parameter_client('/nobody').get('x')
    mute = zros_node('mute', start_parameter_services=False)
    frozen = mute.create_service('rcl_interfaces/srv/GetParameters', '/mute/get_parameters')
    client = tool.parameter_client('/mute', timeout=0.3)
    assert client.wait_for_node()
    with pytest.raises(ParameterTimeoutError, match=r'did not answer get_parameters within 0\.3 s'):
        client.get('x')
    frozen.close()


def test_node_arguments_and_files(tmp_path: Path, zros_node: Callable[..., Node]) -> None:
    params = tmp_path / 'driver.yaml'
    params.write_text(
        '/robot/driver:\n  ros__parameters:\n    speed: 0.7\n    name: from_file\n'
        '/**:\n  ros__parameters:\n    everyone: 1\n'
    )
    node = zros_node(
        'driver',
        '/robot',
        parameters={'speed': 0.1, 'limit': 3},
        args=['--ros-args', '--params-file', str(params), '-p', 'name:=from_cli',
              '-p', 'other_node:name:=not_mine', '-p', 'driver:limit:=9'],
    )  # fmt: skip
    assert node.declare_parameter('speed', 0.5) == 0.7
    assert node.declare_parameter('name', 'default') == 'from_cli'
    assert node.declare_parameter('limit', 0) == 9
    assert node.declare_parameter('everyone', 0) == 1
    assert not node.has_parameter('unrelated')
    free = zros_node('free', parameters={'a': 1, 'b': 'x'}, allow_undeclared_parameters=True)
    assert free.get_parameter('a') == 1 and free.get_parameter('b') == 'x'
    with pytest.raises(ParameterError, match='cannot read the parameter file'):
        zros_node('broken', params_file=tmp_path / 'missing.yaml')


def test_use_sim_time_is_a_parameter(zros_node: Callable[..., Node]) -> None:
    node = zros_node('timed', args=['--ros-args', '-p', 'use_sim_time:=true'])
    assert node.use_sim_time and node.get_parameter('use_sim_time') is True
    node.set_parameter('use_sim_time', False)  # switches at run time, as in ROS 2
    assert not node.use_sim_time and node.get_parameter('use_sim_time') is False
    with pytest.raises(ParameterError, match='use_sim_time'):
        node.set_parameter('use_sim_time', 'yes')
    free = zros_node('free', parameters={'use_sim_time': True}, allow_undeclared_parameters=True)
    assert free.use_sim_time
    with pytest.raises(ParameterError, match='use_sim_time is true or false'):
        free.set_parameter('use_sim_time', 'yes')
    assert free.use_sim_time


@pytest.fixture
def rosr(zros_router: Router, zros_wire: str) -> Iterator[Node]:
    node = zros.init('R_node', connect=zros_router.endpoint, handle_sigint=False, wire=zros_wire)
    yield node
    zros.shutdown()


def test_rosr_calls_on_the_own_node(rosr: Node) -> None:
    assert zros.param_type('gain') is None
    zros.param_set('gain', 2)
    assert zros.param_get('gain') == 2 and zros.param_type('gain') == 'integer'
    zros.param_set('gain', 'high')  # declared by param_set: any type may follow
    assert zros.param_type('gain') == 'string'
    zros.param_set('/R_node:list', [1.5, 2.5])  # naming the own node is the same
    assert zros.param_get('list') == [1.5, 2.5] and zros.param_type('list') == 'double_array'
    zros.param_delete('gain')
    assert zros.param_type('gain') is None and zros.param_get('gain', default=0) == 0
    with pytest.raises(ParameterNotDeclaredError, match="node /R_node has no parameter 'gain'"):
        zros.param_get('gain')
    with pytest.raises(ParameterNotDeclaredError):
        zros.param_delete('gain')
    rosr.declare_parameter('fixed', 1, read_only=True)
    with pytest.raises(ParameterError, match='read-only'):
        zros.param_set('fixed', 2)


def test_rosr_calls_on_a_remote_node(rosr: Node, driver: Node) -> None:
    assert zros.param_get('/robot/driver:speed') == 0.5
    assert zros.param_get('speed', node='/robot/driver') == 0.5
    assert zros.param_type('/robot/driver:wheels.count') == 'integer'
    assert zros.param_type('/robot/driver:ghost') is None
    zros.param_set('/robot/driver:speed', 1.5)
    assert driver.get_parameter('speed') == 1.5
    with pytest.raises(ParameterError, match='Wrong parameter type'):
        zros.param_set('/robot/driver:speed', 'fast')
    with pytest.raises(ParameterError, match='read-only'):
        zros.param_set('/robot/driver:wheels.count', 3)
    with pytest.raises(ParameterError, match='Static parameter cannot be undeclared'):
        zros.param_delete('/robot/driver:name')
    with pytest.raises(ParameterNotDeclaredError, match='node /robot/driver has no parameter'):
        zros.param_get('/robot/driver:ghost')
    with pytest.raises(NodeNotFoundError):
        zros.param_get('/nobody:x')


def test_dump_of_a_node(driver: Node) -> None:
    assert driver.parameters.dump().splitlines()[:3] == [
        '/robot/driver:',
        '  ros__parameters:',
        '    name: "driver"',
    ]
