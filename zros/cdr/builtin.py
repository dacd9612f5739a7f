"""The services and actions zros itself needs, defined from their field lists, and the
interface packages whose files ship inside zros (the demo's).

Messages come from the rosbags typestores; these few service and action types are not in them.
Each entry lists fields as ``"type name [default]"`` and constants as ``"type NAME=value"``.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from zros.cdr.model import ActionDef, Definition, ServiceDef
from zros.cdr.parser import parse_action, parse_service

#: Interface packages whose files ship inside zros: package name -> its folder (``msg/X.msg``).
#: The demo's custom type lives with the demo; every zros program and the CLI resolve it.
SHIPPED_PACKAGES: dict[str, Path] = {'rosR_demos': Path(__file__).parent.parent / 'demo'}

_Fields = tuple[str, ...]

#: name -> (request fields, response fields); Iron+ services are marked by their dependencies
_SERVICES: dict[str, tuple[_Fields, _Fields]] = {
    'rcl_interfaces/srv/ListParameters': (
        ('uint64 DEPTH_RECURSIVE=0', 'string[] prefixes', 'uint64 depth'),
        ('rcl_interfaces/ListParametersResult result',),
    ),
    'rcl_interfaces/srv/GetParameters': (
        ('string[] names',),
        ('rcl_interfaces/ParameterValue[] values',),
    ),
    'rcl_interfaces/srv/SetParameters': (
        ('rcl_interfaces/Parameter[] parameters',),
        ('rcl_interfaces/SetParametersResult[] results',),
    ),
    'rcl_interfaces/srv/SetParametersAtomically': (
        ('rcl_interfaces/Parameter[] parameters',),
        ('rcl_interfaces/SetParametersResult result',),
    ),
    'rcl_interfaces/srv/GetParameterTypes': (
        ('string[] names',),
        ('uint8[] types',),
    ),
    'rcl_interfaces/srv/DescribeParameters': (
        ('string[] names',),
        ('rcl_interfaces/ParameterDescriptor[] descriptors',),
    ),
    'rcl_interfaces/srv/GetLoggerLevels': (
        ('string[] names',),
        ('rcl_interfaces/LoggerLevel[] levels',),
    ),
    'rcl_interfaces/srv/SetLoggerLevels': (
        ('rcl_interfaces/LoggerLevel[] levels',),
        ('rcl_interfaces/SetLoggerLevelsResult[] results',),
    ),
    'action_msgs/srv/CancelGoal': (
        ('action_msgs/GoalInfo goal_info',),
        (
            'int8 ERROR_NONE=0',
            'int8 ERROR_REJECTED=1',
            'int8 ERROR_UNKNOWN_GOAL_ID=2',
            'int8 ERROR_GOAL_TERMINATED=3',
            'int8 return_code',
            'action_msgs/GoalInfo[] goals_canceling',
        ),
    ),
    'type_description_interfaces/srv/GetTypeDescription': (
        ('string type_name', 'string type_hash', 'bool include_type_sources true'),
        (
            'bool successful',
            'string failure_reason',
            'type_description_interfaces/TypeDescription type_description',
            'type_description_interfaces/TypeSource[] type_sources',
            'type_description_interfaces/KeyValue[] extra_information',
        ),
    ),
    'std_srvs/srv/Empty': ((), ()),
    'std_srvs/srv/Trigger': ((), ('bool success', 'string message')),
    'std_srvs/srv/SetBool': (('bool data',), ('bool success', 'string message')),
    'example_interfaces/srv/AddTwoInts': (('int64 a', 'int64 b'), ('int64 sum',)),
}

#: name -> (goal fields, result fields, feedback fields)
_ACTIONS: dict[str, tuple[_Fields, _Fields, _Fields]] = {
    'example_interfaces/action/Fibonacci': (
        ('int32 order',),
        ('int32[] sequence',),
        ('int32[] sequence',),
    ),
}

#: the origin of built-in definitions
BUILTIN_ORIGIN = 'zros built-in definition'
_ORIGIN = BUILTIN_ORIGIN


def _text(*sections: _Fields) -> str:
    return '\n---\n'.join('\n'.join(section) for section in sections)


def builtin_names() -> list[str]:
    """Names of every built-in service and action."""
    return [*_SERVICES, *_ACTIONS]


def builtin_definition(name: str) -> Definition | None:
    """The built-in definition of ``name``, or None when zros does not define it."""
    # no source text: these field lists stand for files whose text (comments) lies elsewhere
    if name in _SERVICES:
        service: ServiceDef = parse_service(name, _text(*_SERVICES[name]), _ORIGIN)
        return replace(service, source='')
    if name in _ACTIONS:
        action: ActionDef = parse_action(name, _text(*_ACTIONS[name]), _ORIGIN)
        return replace(action, source='')
    return None
