"""Helpers of the rclpy interop tests: the installed types, their rclpy classes, value conversion.

Import this module only after checking that rclpy is importable.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from typing import Any

from zros.cdr.model import FieldType, Kind
from zros.cdr.naming import attribute_name
from zros.cdr.registry import TypeRegistry

SHARE = Path(sys.prefix) / 'share'

SERVICE_PARTS = ('_Request', '_Response', '_Event')

#: zros suffix of an action's derived message -> attribute path on the rclpy action class
ACTION_PARTS: dict[str, tuple[str, ...]] = {
    '_Goal': ('Goal',),
    '_Result': ('Result',),
    '_Feedback': ('Feedback',),
    '_SendGoal_Request': ('Impl', 'SendGoalService', 'Request'),
    '_SendGoal_Response': ('Impl', 'SendGoalService', 'Response'),
    '_GetResult_Request': ('Impl', 'GetResultService', 'Request'),
    '_GetResult_Response': ('Impl', 'GetResultService', 'Response'),
    '_FeedbackMessage': ('Impl', 'FeedbackMessage'),
    # not asked for by the ROS docs, but Jazzy generates them and zros knows them too
    '_SendGoal_Event': ('Impl', 'SendGoalService', 'Event'),
    '_GetResult_Event': ('Impl', 'GetResultService', 'Event'),
}


def make_registry() -> TypeRegistry:
    """A registry reading exactly the definitions the installed ROS wheels were built from."""
    return TypeRegistry('jazzy', paths=[SHARE], ament=False)


def _importable(module: str) -> bool:
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True


def installed_interfaces() -> list[str]:
    """``pkg/kind/Name`` of every .msg/.srv/.action installed with an importable Python module."""
    names = []
    for kind in ('msg', 'srv', 'action'):
        for path in sorted(SHARE.glob(f'*/{kind}/*.{kind}')):
            package = path.parent.parent.name
            if _importable(f'{package}.{kind}'):
                names.append(f'{package}/{kind}/{path.stem}')
    return names


def message_type_names(interfaces: list[str]) -> list[str]:
    """Every CDR message type of the given interfaces (derived service/action messages too)."""
    names: list[str] = []
    for name in interfaces:
        kind = name.split('/')[1]
        if kind == 'msg':
            names.append(name)
        elif kind == 'srv':
            names += [name + suffix for suffix in SERVICE_PARTS]
        else:
            names += [name + suffix for suffix in ACTION_PARTS]
    return names


def rclpy_class(name: str) -> Any:
    """The rclpy message class of a zros message type name (derived names included)."""
    package, kind, short = name.split('/')
    module = importlib.import_module(f'{package}.{kind}')
    if kind == 'msg':
        return getattr(module, short)
    if kind == 'srv':
        for suffix in SERVICE_PARTS:
            if short.endswith(suffix):
                return getattr(getattr(module, short[: -len(suffix)]), suffix[1:])
    else:
        for suffix, path in sorted(ACTION_PARTS.items(), key=lambda item: -len(item[0])):
            if short.endswith(suffix):
                obj = getattr(module, short[: -len(suffix)])
                for part in path:
                    obj = getattr(obj, part)
                return obj
    raise LookupError(f'no rclpy class for {name}')


# --- zros value -> rclpy value ----------------------------------------------------------------


def _scalar(registry: TypeRegistry, ftype: FieldType, value: Any) -> Any:
    base = ftype.base
    if base == 'bool':
        return bool(value)
    if base == 'byte':
        return bytes([int(value)])  # rclpy: a bytes object of length 1
    if base in ('float32', 'float64'):
        return float(value)
    if ftype.is_primitive:
        return int(value)  # char too: rclpy keeps it as an int
    if ftype.is_string:
        return str(value)
    return to_rclpy(registry, base, value)


def field_to_rclpy(registry: TypeRegistry, ftype: FieldType, value: Any) -> Any:
    """The rclpy value of one field from its zros value."""
    if ftype.kind is Kind.SCALAR:
        return _scalar(registry, ftype, value)
    element = ftype.element
    if ftype.is_primitive:
        # numpy array in zros -> a plain list; the rclpy setter makes its numpy/array.array form
        return [_scalar(registry, element, item) for item in value.tolist()]
    return [_scalar(registry, element, item) for item in value]


def to_rclpy(registry: TypeRegistry, name: str, message: Any) -> Any:
    """The rclpy message equal to a zros message of type ``name``."""
    definition = registry.message_definition(name)
    result = rclpy_class(name)()
    for f in definition.fields:
        setattr(
            result,
            f.name,
            field_to_rclpy(registry, f.type, getattr(message, attribute_name(f.name))),
        )
    return result
