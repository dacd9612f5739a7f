"""Parameters between zros and real ROS 2 (rclpy) through a zenoh-bridge-ros2dds (issue 7).

* rclpy -> zros: an rclpy ``AsyncParameterClient`` (in the worker) lists, gets, sets (valid
  values, refusals with their reasons, all-or-nothing atomic sets), describes and types the
  parameters of a zros node, which serves the six ``rcl_interfaces`` services through the bridge
  without spinning, and receives the node's ``/parameter_events``.
* zros -> rclpy: ``node.parameter_client()`` does the same to an rclpy node's parameters, and
  ``subscribe_parameter_events`` sees that node's events.

Both ways with every value type (bool, int64, double, string and the byte, bool, int64, double
and string arrays). The bridge is the stand-in of ``bridge_standin`` unless
``ZROS_INTEROP_BRIDGE`` names a real one (see ``rig.py``). Values travel to and from the worker
as JSON (see ``ros_worker.py``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import pytest

pytest.importorskip(
    'rclpy.parameter_client',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)

from tests.interop import rig
from tests.interop.conftest import Interop
from zros.params import (
    Descriptor,
    Parameter,
    ParameterError,
    ParameterEvent,
    ParameterType,
    SetResult,
    subscribe_parameter_events,
)
from zros.params.server import SERVICE_TYPES
from zros.params.values import infer_type
from zros.testing import spinning, wait_for

TIMEOUT = rig.DEADLINE
T = ParameterType

#: name -> (value, descriptor fields): every type, a read-only one, ranges, nested names
DECLARED: dict[str, tuple[Any, dict[str, Any]]] = {
    'flag': (True, {}),
    'count': (4, {'integer_range': (0, 10, 2), 'description': 'even, 0 to 10'}),
    'gain': (0.5, {'floating_point_range': (0.0, 1.0, 0.0)}),
    'label': ('hello', {'additional_constraints': 'any text'}),
    'blob': (b'\x00\x7f\xff', {}),
    'flags': ([True, False, True], {}),
    'ids': ([1, -2, 2**40], {}),
    'weights': ([0.25, -1.5, 1e300], {}),
    'names': (['a', 'ß', ''], {}),
    'frozen': ('ice', {'read_only': True, 'description': 'never changes'}),
    'nested.inner.leaf': (7, {}),
    'nested.top': ('x', {}),
}
KINDS = {
    'flag': T.BOOL,
    'count': T.INTEGER,
    'gain': T.DOUBLE,
    'label': T.STRING,
    'blob': T.BYTE_ARRAY,
    'flags': T.BOOL_ARRAY,
    'ids': T.INTEGER_ARRAY,
    'weights': T.DOUBLE_ARRAY,
    'names': T.STRING_ARRAY,
    'frozen': T.STRING,
    'nested.inner.leaf': T.INTEGER,
    'nested.top': T.STRING,
}
#: a new valid value of every type (range edges, int64 extremes)
NEW: dict[str, Any] = {
    'flag': False,
    'count': 10,
    'gain': 1.0,
    'label': 'world',
    'blob': b'\x01\x02',
    'flags': [False],
    'ids': [-(2**63), 2**63 - 1],
    'weights': [0.0, 3.5, float('-inf')],
    'names': ['x', 'y z'],
}


# --- JSON of the worker ---------------------------------------------------------------------------


def jvalue(value: Any, kind: ParameterType | None = None) -> dict[str, Any]:
    """The worker's JSON of a parameter value."""
    kind = infer_type(value) if kind is None else kind
    return {'type': int(kind), 'value': value.hex() if kind is T.BYTE_ARRAY else value}


def jparam(name: str, value: Any, kind: ParameterType | None = None) -> dict[str, Any]:
    return {'name': name, **jvalue(value, kind)}


def jdescriptor(descriptor: Descriptor) -> dict[str, Any]:
    return {
        'name': descriptor.name,
        'type': int(descriptor.type),
        'description': descriptor.description,
        'additional_constraints': descriptor.additional_constraints,
        'read_only': descriptor.read_only,
        'dynamic_typing': descriptor.dynamic_typing,
        'integer_range': list(descriptor.integer_range) if descriptor.integer_range else None,
        'floating_point_range': (
            [float(x) for x in descriptor.floating_point_range]
            if descriptor.floating_point_range
            else None
        ),
    }


def jspec(name: str, value: Any, fields: dict[str, Any]) -> dict[str, Any]:
    """A parameter of the worker's ``param_node`` (declared with a descriptor)."""
    descriptor = {
        key: list(item) if isinstance(item, tuple) else item for key, item in fields.items()
    }
    return {**jparam(name, value), 'descriptor': descriptor}


def jevent(
    node: str,
    new: Sequence[dict[str, Any]] = (),
    changed: Sequence[dict[str, Any]] = (),
    deleted: Sequence[str] = (),
) -> dict[str, Any]:
    """The worker's JSON of a ``/parameter_events`` message."""
    return {
        'node': node,
        'new': list(new),
        'changed': list(changed),
        'deleted': [jparam(name, None, T.NOT_SET) for name in deleted],
    }


def ok(count: int) -> list[dict[str, Any]]:
    return [{'successful': True, 'reason': ''}] * count


# --- fixtures -------------------------------------------------------------------------------------


class ParamRig:
    """Parameter clients, event recorders and nodes made on the worker, destroyed after a test."""

    def __init__(self, interop: Interop) -> None:
        self.interop = interop
        self.ros = interop.ros.worker
        self.made: list[str] = []

    def client(self, node: str) -> str:
        """An rclpy AsyncParameterClient of ``node`` whose six services are ready."""
        name, ready = self.ros.param_client(node, TIMEOUT)
        self.made.append(name)
        assert ready, f'the parameter services of {node} did not reach the ROS graph'
        return name

    def call(self, client: str, op: str, **args: Any) -> dict[str, Any]:
        return self.ros.param_call(client, op, TIMEOUT, **args)

    def events(self, client: str) -> str:
        name = self.ros.param_events(client)
        self.made.append(name)
        return name

    def node(self, parameters: list[dict[str, Any]]) -> tuple[str, str]:
        """An rclpy node (uniquely named) declaring ``parameters``; handle and FQN."""
        node_name = self.interop.topic('ros_params')[1:]
        name, fqn = self.ros.param_node(node_name, parameters)
        self.made.append(name)
        return name, fqn

    def cleanup(self) -> None:
        for name in reversed(self.made):
            self.ros.destroy(name)
        self.made.clear()


@pytest.fixture
def params(interop: Interop) -> Iterator[ParamRig]:
    rig = ParamRig(interop)
    yield rig
    rig.cleanup()


def zros_node(interop: Interop, name: str | None = None, **options: Any) -> Any:
    """A zros node serving its parameters (all of DECLARED) through the bridge."""
    node = interop.node(
        name or interop.topic('zros_params')[1:], start_parameter_services=True, **options
    )
    for parameter, (value, fields) in DECLARED.items():
        node.declare_parameter(parameter, value, **fields)
    return node


def wait_for_parameter_services(node: Any, target: str) -> bool:
    """Whether all six parameter services of ``target`` become reachable from ``node``."""
    clients = [node.create_client(kind, f'{target}/{name}') for name, kind in SERVICE_TYPES.items()]
    try:
        return all(client.wait_for_service(TIMEOUT) for client in clients)
    finally:
        for client in clients:
            client.close()


def until_events_flow(trigger: Callable[[int], None], seen: Callable[[int, float], bool]) -> bool:
    """Make changes (``trigger(n)``, n = 1, 2...) until the event of the latest one is ``seen``.

    ``/parameter_events`` is volatile: events sent before the subscriber's path through the
    bridge is complete are lost. Events arrive in order, so once the latest change's is seen,
    every earlier one is in too.
    """
    deadline = time.monotonic() + TIMEOUT
    attempt = 0
    while time.monotonic() < deadline:
        attempt += 1
        trigger(attempt)
        if seen(attempt, min(0.5, max(0.0, deadline - time.monotonic()))):
            return True
    return False


# --- rclpy clients, zros parameters --------------------------------------------------------------


def test_ros_client_lists_gets_types_and_describes_zros_parameters(
    interop: Interop, params: ParamRig
) -> None:
    node = zros_node(interop, 'zros_node')
    assert node.fully_qualified_name == '/zros_node'
    client = params.client('/zros_node')

    names = sorted([*DECLARED, 'use_sim_time'])
    listed = params.call(client, 'list')
    assert listed == {'names': names, 'prefixes': ['nested.inner', 'nested']}
    assert listed['names'] == node.parameters.list_parameters()[0]
    assert params.call(client, 'list', prefixes=['nested'], depth=1) == {
        'names': ['nested.top'],
        'prefixes': ['nested'],
    }
    assert params.call(client, 'list', prefixes=['nested'], depth=2) == {
        'names': ['nested.inner.leaf', 'nested.top'],
        'prefixes': ['nested.inner', 'nested'],
    }

    got = params.call(client, 'get', names=list(DECLARED))['values']
    assert got == [jvalue(value, KINDS[name]) for name, (value, _) in DECLARED.items()]
    assert params.call(client, 'get', names=['use_sim_time', 'ghost'])['values'] == [
        jvalue(False),
        jvalue(None, T.NOT_SET),
    ]
    types = params.call(client, 'types', names=[*DECLARED, 'ghost'])['types']
    assert types == [int(KINDS[name]) for name in DECLARED] + [int(T.NOT_SET)]

    everything = [*DECLARED, 'use_sim_time']
    described = params.call(client, 'describe', names=everything)['descriptors']
    assert described == [jdescriptor(node.parameters.describe(name)) for name in everything]
    by_name = {item['name']: item for item in described}
    assert by_name['count']['integer_range'] == [0, 10, 2]
    assert by_name['count']['description'] == 'even, 0 to 10'
    assert by_name['gain']['floating_point_range'] == [0.0, 1.0, 0.0]
    assert by_name['label']['additional_constraints'] == 'any text'
    assert by_name['frozen']['read_only'] and not by_name['label']['read_only']
    assert by_name['blob']['type'] == T.BYTE_ARRAY


def test_ros_client_sets_zros_parameters(interop: Interop, params: ParamRig) -> None:
    node = zros_node(interop)
    client = params.client(node.fully_qualified_name)

    # every type at once: set_parameters sets each on its own
    reply = params.call(client, 'set', parameters=[jparam(n, v) for n, v in NEW.items()])
    assert reply['results'] == ok(len(NEW))
    for name, value in NEW.items():
        assert node.get_parameter(name) == value, name  # set without the node spinning
    got = params.call(client, 'get', names=list(NEW))['values']
    assert got == [jvalue(value, KINDS[name]) for name, value in NEW.items()]

    # refusals, each with rclcpp's reason; the valid one among them still goes through
    refused = [
        jparam('count', 'ten'),
        jparam('frozen', 'melt'),
        jparam('count', 12),
        jparam('count', 3),  # not on a step of 2
        jparam('gain', 1.5),
        jparam('gain', -0.1),
        jparam('ids', [1.5]),
        jparam('ghost', 1),
        jparam('label', 'still works'),
    ]
    results = params.call(client, 'set', parameters=refused)['results']
    assert results == [
        {
            'successful': False,
            'reason': 'Wrong parameter type, parameter {count} is of type {integer}, '
            'setting it to {string} is not allowed.',
        },
        {
            'successful': False,
            'reason': "parameter 'frozen' cannot be set because it is read-only",
        },
        {'successful': False, 'reason': "Parameter {count} doesn't comply with integer range."},
        {'successful': False, 'reason': "Parameter {count} doesn't comply with integer range."},
        {
            'successful': False,
            'reason': "Parameter {gain} doesn't comply with floating point range.",
        },
        {
            'successful': False,
            'reason': "Parameter {gain} doesn't comply with floating point range.",
        },
        {
            'successful': False,
            'reason': 'Wrong parameter type, parameter {ids} is of type {integer_array}, '
            'setting it to {double_array} is not allowed.',
        },
        {
            'successful': False,
            'reason': "parameter 'ghost' cannot be set because it was not declared",
        },
        {'successful': True, 'reason': ''},
    ]
    assert node.parameters.values() == {
        **{name: value for name, (value, _) in DECLARED.items()},
        **NEW,
        'label': 'still works',
        'use_sim_time': False,
    }
    assert not node.has_parameter('ghost')
    # a static parameter cannot be deleted
    deleted = params.call(client, 'delete', names=['count'])['results']
    assert deleted == [
        {
            'successful': False,
            'reason': 'Static parameter cannot be undeclared, parameter {count} is of type '
            '{integer}',
        }
    ]
    assert node.get_parameter('count') == NEW['count']


def test_ros_client_sets_zros_parameters_atomically(interop: Interop, params: ParamRig) -> None:
    node = zros_node(interop)
    client = params.client(node.fully_qualified_name)
    before = node.parameters.values()

    one_bad = [jparam('flag', False), jparam('blob', b'\x09'), jparam('count', 11)]
    reply = params.call(client, 'set_atomically', parameters=one_bad)
    assert reply == {
        'result': {
            'successful': False,
            'reason': "Parameter {count} doesn't comply with integer range.",
        }
    }
    assert node.parameters.values() == before  # none of them
    read_only = [jparam('weights', [1.0]), jparam('frozen', 'melt')]
    reply = params.call(client, 'set_atomically', parameters=read_only)
    assert reply['result'] == {
        'successful': False,
        'reason': "parameter 'frozen' cannot be set because it is read-only",
    }
    assert node.parameters.values() == before

    all_good = [jparam(name, value) for name, value in NEW.items()]
    reply = params.call(client, 'set_atomically', parameters=all_good)
    assert reply == {'result': {'successful': True, 'reason': ''}}
    assert node.parameters.values() == {**before, **NEW}  # all of them
    got = params.call(client, 'get', names=list(NEW))['values']
    assert got == [jvalue(value, KINDS[name]) for name, value in NEW.items()]


def test_ros_client_receives_zros_parameter_events(interop: Interop, params: ParamRig) -> None:
    node = zros_node(interop, allow_undeclared_parameters=True)
    fqn = node.fully_qualified_name
    node.declare_parameter('tick', 0)
    client = params.client(fqn)
    recorder = params.events(client)

    def tick_seen(attempt: int, timeout: float) -> bool:
        events = params.ros.wait_param_events(recorder, fqn, 1, timeout)
        return jevent(fqn, changed=[jparam('tick', attempt)]) in events

    assert until_events_flow(lambda n: node.set_parameter('tick', n), tick_seen)
    start = len(params.ros.wait_param_events(recorder, fqn, 1, TIMEOUT))

    node.declare_parameter('fresh', [1.5, 2.5])  # zros declares
    set_by_ros = [jparam('fresh', [3.0]), jparam('made_remotely', b'\x05')]
    assert params.call(client, 'set', parameters=set_by_ros)['results'] == ok(2)
    assert node.get_parameter('made_remotely') == b'\x05'
    assert params.call(client, 'delete', names=['made_remotely'])['results'] == ok(1)
    assert not node.has_parameter('made_remotely')
    node.undeclare_parameter('fresh')  # zros undeclares
    node.set_parameter('names', ['set', 'by', 'zros'])  # zros sets
    assert params.call(client, 'set_atomically', parameters=[jparam('flag', False)]) == {
        'result': {'successful': True, 'reason': ''}
    }

    expected = [
        jevent(fqn, new=[jparam('fresh', [1.5, 2.5])]),
        jevent(fqn, changed=[jparam('fresh', [3.0])]),
        jevent(fqn, new=[jparam('made_remotely', b'\x05')]),
        jevent(fqn, deleted=['made_remotely']),
        jevent(fqn, deleted=['fresh']),
        jevent(fqn, changed=[jparam('names', ['set', 'by', 'zros'])]),
        jevent(fqn, changed=[jparam('flag', False)]),
    ]
    events = params.ros.wait_param_events(recorder, fqn, start + len(expected), TIMEOUT)
    assert events[start:] == expected


# --- zros clients, rclpy parameters --------------------------------------------------------------

#: the rclpy node's parameters: DECLARED, a dynamically typed one and a counter for syncing
ROS_DECLARED: dict[str, tuple[Any, dict[str, Any]]] = {
    **DECLARED,
    'scratch': ('anything', {'dynamic_typing': True}),
    'tick': (0, {}),
}


def ros_node(params: ParamRig) -> tuple[str, str]:
    return params.node([jspec(name, value, f) for name, (value, f) in ROS_DECLARED.items()])


def test_zros_reads_and_describes_ros_parameters(interop: Interop, params: ParamRig) -> None:
    _, fqn = ros_node(params)
    node = interop.node()
    assert wait_for_parameter_services(node, fqn)
    remote = node.parameter_client(fqn, TIMEOUT)
    assert remote.wait_for_node(TIMEOUT)

    # the same listing as rclpy's own client gives
    truth = params.call(params.client(fqn), 'list')
    names = remote.list_parameters()
    assert names == truth['names']
    assert set(names) >= {*ROS_DECLARED, 'use_sim_time'}
    assert remote.list_parameters(['nested'], 1) == ['nested.top']

    values = {name: value for name, (value, _) in ROS_DECLARED.items()}
    assert remote.get_parameters(list(values)) == values
    # rclpy answers no values at all when one name is unknown: zros asks one by one
    assert remote.get_parameters(['flag', 'ghost', 'ids']) == {
        'flag': True,
        'ghost': None,
        'ids': values['ids'],
    }
    assert remote.get('blob') == b'\x00\x7f\xff'
    kinds = {**KINDS, 'scratch': T.STRING, 'tick': T.INTEGER}
    assert remote.get_parameter_types(list(ROS_DECLARED)) == {name: kinds[name] for name in kinds}

    described = remote.describe_parameters(list(ROS_DECLARED))
    for name, (_, fields) in ROS_DECLARED.items():
        assert described[name] == Descriptor(name=name, type=kinds[name], **fields), name


def test_zros_sets_ros_parameters(interop: Interop, params: ParamRig) -> None:
    handle, fqn = ros_node(params)
    node = interop.node()
    assert wait_for_parameter_services(node, fqn)
    remote = node.parameter_client(fqn, TIMEOUT)
    truth = params.client(fqn)

    assert remote.set_parameters(NEW) == [SetResult(True)] * len(NEW)
    # the rclpy node has them, as rclpy's own client reads them
    got = params.call(truth, 'get', names=list(NEW))['values']
    assert got == [jvalue(value, KINDS[name]) for name, value in NEW.items()]
    assert remote.get_parameters(list(NEW)) == NEW

    # refusals, each with rclpy's reason; the valid one among them still goes through
    # Parameter items, not a mapping: 'count' comes more than once
    attempts = [
        ('count', 'ten'),
        ('frozen', 'melt'),
        ('count', 12),
        ('count', 3),
        ('gain', 1.5),
        ('ghost', 1),
        ('count', None),
        ('label', 'still works'),
    ]
    results = remote.set_parameters([Parameter(name, value) for name, value in attempts])
    assert results == [
        SetResult(False, "Wrong parameter type, expected 'Type.INTEGER' got 'Type.STRING'"),
        SetResult(False, 'Trying to set a read-only parameter: frozen.'),
        SetResult(False, 'Parameter count out of range. Min: 0, Max: 10, value: 12'),
        SetResult(
            False,
            'The parameter value for count is not a valid step. Min: 0, max: 10, value: 3, step: 2',
        ),
        SetResult(False, 'Parameter gain out of range Min: 0.0, Max: 1.0, value: 1.5'),
        # rclpy's text (it lists no names: Jazzy formats the exception's args oddly)
        SetResult(False, results[5].reason),
        SetResult(False, 'Static parameter cannot be undeclared'),
        SetResult(True),
    ]
    assert results[5].reason.startswith('Invalid access to undeclared parameter(s)')
    with pytest.raises(ParameterError, match=r'read-only parameter: frozen\.'):
        remote.set('frozen', 'melt')
    expected = {**NEW, 'label': 'still works', 'frozen': 'ice'}
    got = params.call(truth, 'get', names=list(expected))['values']
    assert got == [jvalue(value, KINDS[name]) for name, value in expected.items()]

    # all or nothing
    one_bad = {'flag': True, 'names': ['no'], 'gain': 2.0}
    assert remote.set_parameters_atomically(one_bad) == SetResult(
        False, 'Parameter gain out of range Min: 0.0, Max: 1.0, value: 2.0'
    )
    assert remote.get_parameters(list(one_bad)) == {name: expected[name] for name in one_bad}
    all_good = {'flag': True, 'names': ['yes'], 'gain': 0.0, 'blob': b'', 'scratch': 42}
    assert remote.set_parameters_atomically(all_good) == SetResult(True)
    assert remote.get_parameters(list(all_good)) == all_good
    assert remote.get_parameter_types(['scratch']) == {'scratch': T.INTEGER}  # dynamic typing
    assert params.ros.param_node_op(handle, 'set', [jparam('count', 6)]) == ok(1)
    assert remote.get('count') == 6  # a change made by the node itself


def test_zros_receives_ros_parameter_events(interop: Interop, params: ParamRig) -> None:
    handle, fqn = ros_node(params)
    node = interop.node()
    received: list[ParameterEvent] = []
    subscribe_parameter_events(node, received.append, node_name=fqn)
    assert wait_for_parameter_services(node, fqn)
    remote = node.parameter_client(fqn, TIMEOUT)

    with spinning(node):

        def tick_seen(attempt: int, timeout: float) -> bool:
            return wait_for(
                lambda: any(event.changed == {'tick': attempt} for event in list(received)),
                timeout,
            )

        assert until_events_flow(lambda n: remote.set('tick', n), tick_seen)
        start = len(received)

        params.ros.param_node_op(handle, 'declare', [jspec('late', [0.5], {})])
        remote.set('label', 'set by zros')
        remote.set('scratch', None)  # deletes a dynamically typed parameter
        assert params.ros.param_node_op(handle, 'set', [jparam('ids', [9])]) == ok(1)
        assert remote.set_parameters_atomically({'flags': [True], 'blob': b'\x01'})
        assert wait_for(lambda: len(received) >= start + 5, TIMEOUT)

    events = received[start:]
    assert {event.node for event in events} == {fqn}
    assert [(event.new, event.changed, event.deleted) for event in events] == [
        ({'late': [0.5]}, {}, []),
        ({}, {'label': 'set by zros'}, []),
        ({}, {}, ['scratch']),
        ({}, {'ids': [9]}, []),
        ({}, {'flags': [True], 'blob': b'\x01'}, []),
    ]
    assert all(event.stamp.nanoseconds > 0 for event in events)
    assert remote.get('scratch') is None
