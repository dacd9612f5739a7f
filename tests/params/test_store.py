"""A node's parameter store: declaring, types, ranges, read-only, callbacks, listing."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from zros.params import (
    Descriptor,
    Parameter,
    ParameterError,
    ParameterNotDeclaredError,
    ParameterStore,
    ParameterType,
    SetResult,
)
from zros.params.values import from_message, infer_type, to_message


@pytest.mark.parametrize(
    ('value', 'kind'),
    [
        (True, ParameterType.BOOL), (3, ParameterType.INTEGER), (2.5, ParameterType.DOUBLE),
        ('x', ParameterType.STRING), (b'\x01', ParameterType.BYTE_ARRAY),
        ([True], ParameterType.BOOL_ARRAY), ([1, 2], ParameterType.INTEGER_ARRAY),
        ([1.0, 2], ParameterType.DOUBLE_ARRAY), (('a', 'b'), ParameterType.STRING_ARRAY),
        (np.arange(3), ParameterType.INTEGER_ARRAY), (np.float32(1.5), ParameterType.DOUBLE),
        (np.array([1, 2], dtype=np.uint8), ParameterType.BYTE_ARRAY), (None, ParameterType.NOT_SET),
    ],
)  # fmt: skip
def test_types_of_python_values(value: Any, kind: ParameterType) -> None:
    assert infer_type(value) is kind


@pytest.mark.parametrize(
    ('value', 'message'),
    [
        ([], 'an empty list has no parameter type'),
        ([1, 'a'], 'one type, not integer and string'),
        ([[1]], 'holds values no parameter can'),
        ({'a': 1}, 'dict is not a parameter type'),
    ],
)
def test_values_no_parameter_can_hold(value: Any, message: str) -> None:
    with pytest.raises(ParameterError, match=message):
        infer_type(value)


@pytest.mark.parametrize(
    'value', [True, -(2**63), 1.5, 'grüße', b'\x00\x01', [False, True], [1, 2], [0.5], ['a', '']]
)
def test_messages_round_trip(value: Any) -> None:
    import zros

    message_class = zros.get_type('rcl_interfaces/msg/ParameterValue')
    kind = infer_type(value)
    assert from_message(to_message(value, kind, message_class)) == (value, kind)


def test_declare_get_and_overrides() -> None:
    store = ParameterStore('/robot/driver', overrides={'speed': 0.8})
    assert store.declare('speed', 0.5) == 0.8  # the override wins
    assert store.declare('name', 'driver') == 'driver'
    assert store.declare('plain', 0.5, ignore_override=True) == 0.5
    assert store.get('speed') == 0.8 and store.type_of('speed') is ParameterType.DOUBLE
    with pytest.raises(ParameterError, match="parameter 'speed' has already been declared"):
        store.declare('speed', 1.0)
    with pytest.raises(ParameterNotDeclaredError, match="parameter 'nope' is not declared"):
        store.get('nope')
    assert store.type_of('nope') is ParameterType.NOT_SET
    assert store.describe('nope').type is ParameterType.NOT_SET


def test_static_typing_and_the_reasons_ros_tools_show() -> None:
    store = ParameterStore('/n')
    store.declare('speed', 0.5)
    store.declare('count', 3)
    store.declare('mode', 'fast', read_only=True)
    assert store.set('speed', 2.0) and store.get('speed') == 2.0
    assert store.set('speed', 2) == SetResult(  # ROS's rule, as ros2 param set meets it
        False,
        'Wrong parameter type, parameter {speed} is of type {double}, setting it to {integer} '
        'is not allowed. speed is a double: write 2.0',
    )
    result = store.set('count', 'three')
    assert result == SetResult(
        False,
        'Wrong parameter type, parameter {count} is of type {integer}, setting it to {string} '
        'is not allowed.',
    )
    assert store.set('mode', 'slow') == SetResult(
        False, "parameter 'mode' cannot be set because it is read-only"
    )
    assert store.set('ghost', 1) == SetResult(
        False, "parameter 'ghost' cannot be set because it was not declared"
    )
    assert store.set('count', None) == SetResult(
        False, 'Static parameter cannot be undeclared, parameter {count} is of type {integer}'
    )
    assert store.get('count') == 3


def test_dynamic_typing() -> None:
    store = ParameterStore('/n')
    store.declare('anything', 1, dynamic_typing=True)
    assert store.set('anything', 'now a string')
    assert store.type_of('anything') is ParameterType.STRING
    assert store.set('anything', None) and not store.has('anything')


def test_ranges() -> None:
    store = ParameterStore('/n')
    store.declare('percent', 50, integer_range=(0, 100, 10))
    store.declare('gain', 0.5, floating_point_range=(0.0, 1.0, 0.25))
    store.declare('angles', [0.0], floating_point_range=(-math.pi, math.pi, 0.0))
    assert store.set('percent', 100) and store.set('percent', 0)
    assert store.set('percent', 55) == SetResult(
        False, "Parameter {percent} doesn't comply with integer range."
    )
    assert not store.set('percent', 110)
    assert store.set('gain', 0.75) and store.set('gain', 1.0)
    assert store.set('gain', 0.3) == SetResult(
        False, "Parameter {gain} doesn't comply with floating point range."
    )
    assert not store.set('gain', math.nan)
    assert store.set('angles', [-1.0, 3.0]) and not store.set('angles', [0.0, 4.0])
    with pytest.raises(ParameterError, match='integer range'):
        store.declare('bad_default', 500, integer_range=(0, 100, 1))
    described = store.describe('percent')
    assert described.integer_range == (0, 100, 10) and described.type is ParameterType.INTEGER


def test_atomic_sets_are_all_or_nothing() -> None:
    store = ParameterStore('/n')
    store.declare('a', 1)
    store.declare('b', 'x', read_only=True)
    assert not store.set_atomically({'a': 2, 'b': 'y'})
    assert store.get('a') == 1
    results = store.set_many({'a': 2, 'b': 'y'})
    assert [r.successful for r in results] == [True, False] and store.get('a') == 2


def test_callbacks_can_refuse_and_see_every_change() -> None:
    store = ParameterStore('/n')
    seen: list[list[Parameter]] = []

    def only_positive(parameters: list[Parameter]) -> Any:
        seen.append(parameters)
        for parameter in parameters:
            if isinstance(parameter.value, int) and parameter.value < 0:
                return False, f'{parameter.name} must be positive'
        return None

    store.add_on_set_callback(only_positive)
    store.declare('speed', 1)
    assert store.set('speed', -1) == SetResult(False, 'speed must be positive')
    assert store.set('speed', 5)
    assert [[(p.name, p.value) for p in batch] for batch in seen] == [
        [('speed', 1)],
        [('speed', -1)],
        [('speed', 5)],
    ]
    with pytest.raises(ParameterError, match='must be positive'):
        store.declare('other', -3)

    def broken(parameters: list[Parameter]) -> Any:
        raise RuntimeError('oops')

    store.remove_on_set_callback(only_positive)
    store.add_on_set_callback(broken)
    assert store.set('speed', 6) == SetResult(False, "a set callback raised RuntimeError('oops')")


def test_change_events() -> None:
    events: list[tuple[list[str], list[str], list[str]]] = []
    store = ParameterStore('/n', allow_undeclared=True)
    store.on_change = lambda new, changed, deleted: events.append(
        ([p.name for p in new], [p.name for p in changed], [p.name for p in deleted])
    )
    store.declare('a', 1)
    store.set('a', 1)  # no change, no event
    store.set('a', 2)
    store.set('b', 'new')  # undeclared names are welcome here
    store.set('b', None)
    store.undeclare('a')
    assert events == [(['a'], [], []), ([], ['a'], []), (['b'], [], []), ([], [], ['b']),
                      ([], [], ['a'])]  # fmt: skip


def test_undeclared_mode_declares_overrides() -> None:
    store = ParameterStore('/n', overrides={'x': 1, 'y': [1.5]}, allow_undeclared=True)
    assert store.values() == {'x': 1, 'y': [1.5]}
    assert store.get('unknown') is None
    assert store.describe('x').dynamic_typing


def test_undeclare() -> None:
    store = ParameterStore('/n')
    store.declare('fixed', 1, read_only=True)
    with pytest.raises(ParameterError, match='it is read-only'):
        store.undeclare('fixed')
    with pytest.raises(ParameterNotDeclaredError):
        store.undeclare('ghost')


def test_listing_like_list_parameters() -> None:
    store = ParameterStore('/n')
    for name in ('a', 'b.c', 'b.d.e', 'b.d.f', 'bb'):
        store.declare(name, 1)
    assert store.list_parameters() == (['a', 'b.c', 'b.d.e', 'b.d.f', 'bb'], ['b', 'b.d'])
    assert store.list_parameters(depth=1) == (['a', 'bb'], [])
    assert store.list_parameters(depth=2) == (['a', 'b.c', 'bb'], ['b'])
    assert store.list_parameters(['b']) == (['b.c', 'b.d.e', 'b.d.f'], ['b', 'b.d'])
    assert store.list_parameters(['b'], depth=1) == (['b.c'], ['b'])
    assert store.list_parameters(['b.d', 'a']) == (['a', 'b.d.e', 'b.d.f'], ['b.d'])


def test_descriptor_messages_round_trip() -> None:
    import zros

    registry = zros.get_type('rcl_interfaces/msg/ParameterDescriptor')._registry
    descriptor = Descriptor(
        'gain', ParameterType.DOUBLE, 'how hard', 'none', True, False, None, (0.0, 1.0, 0.1)
    )
    assert Descriptor.from_message(descriptor.to_message(registry)) == descriptor


def test_dump() -> None:
    store = ParameterStore('/robot/driver')
    store.declare('speed', 0.5)
    store.declare('wheels.left', 1)
    assert store.dump() == (
        '/robot/driver:\n  ros__parameters:\n    speed: 0.5\n    wheels:\n      left: 1\n'
    )
