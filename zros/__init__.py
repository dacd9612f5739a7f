"""zros: a pure-Python ROS 2 client over Eclipse Zenoh.

Heavy modules load on first use, so ``import zros`` and the ``zros`` command start fast.
"""

from __future__ import annotations

import importlib

from zros.version import __version__ as __version__

# not ``from typing import TYPE_CHECKING``: importing typing would slow every start-up (``zros
# --help``); mypy reads a name TYPE_CHECKING as true all the same
TYPE_CHECKING = False

#: public name -> (module, attribute), imported on first access
_LAZY = {
    'ZrosError': ('zros.errors', 'ZrosError'),
    'CdrError': ('zros.cdr', 'CdrError'),
    'FieldError': ('zros.cdr', 'FieldError'),
    'UnknownTypeError': ('zros.cdr', 'UnknownTypeError'),
    'InterfaceSyntaxError': ('zros.cdr', 'InterfaceSyntaxError'),
    'get_type': ('zros.cdr', 'get_type'),
    'register_type': ('zros.cdr', 'register_type'),
    'type_hash': ('zros.cdr', 'type_hash'),
    'bag_read': ('zros.bag', 'bag_read'),
    'init': ('zros.api', 'init'),
    'ok': ('zros.api', 'ok'),
    'spin_once': ('zros.api', 'spin_once'),
    'spin': ('zros.api', 'spin'),
    'spin_until_future_complete': ('zros.api', 'spin_until_future_complete'),
    'shutdown': ('zros.api', 'shutdown'),
    'default_node': ('zros.api', 'default_node'),
    'create_node': ('zros.api', 'create_node'),
    'NotInitializedError': ('zros.runtime.defaults', 'NotInitializedError'),
    'get_logger': ('zros.api', 'get_logger'),
    'log': ('zros.api', 'log'),
    'debug': ('zros.api', 'debug'),
    'info': ('zros.api', 'info'),
    'warn': ('zros.api', 'warn'),
    'error': ('zros.api', 'error'),
    'fatal': ('zros.api', 'fatal'),
    'time_now': ('zros.api', 'time_now'),
    'Time': ('zros.runtime.clock', 'Time'),
    'Duration': ('zros.runtime.clock', 'Duration'),
    'Logger': ('zros.runtime.logger', 'Logger'),
    'RosoutHandler': ('zros.runtime.logger', 'RosoutHandler'),
    'Node': ('zros.node', 'Node'),
    'Publisher': ('zros.pubsub', 'Publisher'),
    'Subscriber': ('zros.pubsub', 'Subscriber'),
    'ActionServer': ('zros.actions', 'ActionServer'),
    'ActionClient': ('zros.actions', 'ActionClient'),
    'GoalStatus': ('zros.actions', 'GoalStatus'),
    'GoalResponse': ('zros.actions', 'GoalResponse'),
    'CancelResponse': ('zros.actions', 'CancelResponse'),
    'ActionError': ('zros.actions', 'ActionError'),
    'GoalRejectedError': ('zros.actions', 'GoalRejectedError'),
    'param_set': ('zros.api', 'param_set'),
    'param_get': ('zros.api', 'param_get'),
    'param_type': ('zros.api', 'param_type'),
    'param_delete': ('zros.api', 'param_delete'),
    'Parameter': ('zros.params.rclpy_style', 'Parameter'),
    'ParameterError': ('zros.params', 'ParameterError'),
    'ParameterNotDeclaredError': ('zros.params', 'ParameterNotDeclaredError'),
    'ParameterType': ('zros.params', 'ParameterType'),
    'Descriptor': ('zros.params', 'Descriptor'),
    'SetResult': ('zros.params', 'SetResult'),
    'ParameterClient': ('zros.params', 'ParameterClient'),
    'Service': ('zros.services', 'Service'),
    'Client': ('zros.services', 'Client'),
    'ServiceError': ('zros.services', 'ServiceError'),
    'ServiceUnavailableError': ('zros.services', 'ServiceUnavailableError'),
    'LinkLostError': ('zros.services', 'LinkLostError'),
    'ServiceTimeoutError': ('zros.services', 'ServiceTimeoutError'),
    'ServiceCallError': ('zros.services', 'ServiceCallError'),
    'Timer': ('zros.runtime.timers', 'Timer'),
    'Rate': ('zros.runtime.timers', 'Rate'),
    'QoS': ('zros.qos', 'QoS'),
    'Reliability': ('zros.qos', 'Reliability'),
    'Durability': ('zros.qos', 'Durability'),
    'History': ('zros.qos', 'History'),
    'Congestion': ('zros.qos', 'Congestion'),
    'Priority': ('zros.qos', 'Priority'),
    'InvalidNameError': ('zros.keyexpr.names', 'InvalidNameError'),
    'TransportError': ('zros.transport', 'TransportError'),
    'TransportConfig': ('zros.transport', 'TransportConfig'),
    'start_router': ('zros.transport', 'start_router'),
}

if TYPE_CHECKING:
    from typing import overload

    from zros.actions import (
        ActionClient,
        ActionError,
        ActionServer,
        CancelResponse,
        GoalRejectedError,
        GoalResponse,
        GoalStatus,
    )
    from zros.api import (
        create_node,
        debug,
        default_node,
        error,
        fatal,
        get_logger,
        info,
        init,
        log,
        ok,
        param_delete,
        param_get,
        param_set,
        param_type,
        shutdown,
        spin,
        spin_once,
        spin_until_future_complete,
        time_now,
        warn,
    )
    from zros.bag import bag_read
    from zros.cdr import (
        CdrError,
        FieldError,
        InterfaceSyntaxError,
        UnknownTypeError,
        get_type,
        register_type,
        type_hash,
    )
    from zros.cdr.message import M
    from zros.cdr.message import Message as _MessageBase
    from zros.errors import ZrosError
    from zros.keyexpr.errors import InvalidNameError
    from zros.node import Node
    from zros.params import (
        Descriptor,
        ParameterClient,
        ParameterError,
        ParameterNotDeclaredError,
        ParameterType,
        SetResult,
    )
    from zros.params.rclpy_style import Parameter
    from zros.pubsub import Publisher, Subscriber
    from zros.qos import Congestion, Durability, History, Priority, QoS, Reliability
    from zros.runtime.clock import Duration, Time
    from zros.runtime.defaults import NotInitializedError
    from zros.runtime.logger import Logger, RosoutHandler
    from zros.runtime.timers import Rate, Timer
    from zros.services import (
        Client,
        LinkLostError,
        Service,
        ServiceCallError,
        ServiceError,
        ServiceTimeoutError,
        ServiceUnavailableError,
    )
    from zros.transport import TransportConfig, TransportError, start_router


if TYPE_CHECKING:  # a class gives its own instances, a type name a Message

    @overload
    def Message(type_name: type[M], **fields: object) -> M: ...

    @overload
    def Message(type_name: str, **fields: object) -> _MessageBase: ...


def Message(type_name: str | type[_MessageBase], **fields: object) -> _MessageBase:  # noqa: N802
    """A new message of a ROS type with its default values (rosR: ``ros.Message``).

    A factory, named as rosR named it; what it returns is an instance of a generated class
    whose base, for ``isinstance`` and annotations, is :class:`zros.cdr.Message`.

    >>> import zros
    >>> zros.Message('std_msgs/msg/String', data='hello').data
    'hello'
    """
    from zros.cdr import new_message  # noqa: PLC0415 (import zros stays light: zros.cdr loads numpy)

    return new_message(type_name, **fields)


def __getattr__(name: str) -> object:
    if name in _LAZY:
        module, attribute = _LAZY[name]
        value = getattr(importlib.import_module(module), attribute)
        globals()[name] = value
        return value
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])


__all__ = [
    'ActionClient',
    'ActionError',
    'ActionServer',
    'CancelResponse',
    'CdrError',
    'Client',
    'Congestion',
    'Descriptor',
    'Durability',
    'Duration',
    'FieldError',
    'GoalRejectedError',
    'GoalResponse',
    'GoalStatus',
    'History',
    'InterfaceSyntaxError',
    'InvalidNameError',
    'LinkLostError',
    'Logger',
    'Message',
    'Node',
    'NotInitializedError',
    'Parameter',
    'ParameterClient',
    'ParameterError',
    'ParameterNotDeclaredError',
    'ParameterType',
    'Priority',
    'Publisher',
    'QoS',
    'Rate',
    'Reliability',
    'RosoutHandler',
    'Service',
    'ServiceCallError',
    'ServiceError',
    'ServiceTimeoutError',
    'ServiceUnavailableError',
    'SetResult',
    'Subscriber',
    'Time',
    'Timer',
    'TransportConfig',
    'TransportError',
    'UnknownTypeError',
    'ZrosError',
    'bag_read',
    'create_node',
    'debug',
    'default_node',
    'error',
    'fatal',
    'get_logger',
    'get_type',
    'info',
    'init',
    'log',
    'ok',
    'param_delete',
    'param_get',
    'param_set',
    'param_type',
    'register_type',
    'shutdown',
    'spin',
    'spin_once',
    'spin_until_future_complete',
    'start_router',
    'time_now',
    'type_hash',
    'warn',
]
