"""zros: a pure-Python ROS 2 client over Eclipse Zenoh.

Heavy modules load on first use, so ``import zros`` and the ``zros`` command start fast.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = '0.1.0'

#: public name -> (module, attribute), imported on first access
_LAZY = {
    'ZrosError': ('zros.errors', 'ZrosError'),
    'CdrError': ('zros.cdr', 'CdrError'),
    'UnknownTypeError': ('zros.cdr', 'UnknownTypeError'),
    'InterfaceSyntaxError': ('zros.cdr', 'InterfaceSyntaxError'),
    'get_type': ('zros.cdr', 'get_type'),
    'register_type': ('zros.cdr', 'register_type'),
    'type_hash': ('zros.cdr', 'type_hash'),
}

if TYPE_CHECKING:
    from zros.cdr import (
        CdrError,
        InterfaceSyntaxError,
        UnknownTypeError,
        get_type,
        register_type,
        type_hash,
    )
    from zros.cdr.message import Message as _MessageBase
    from zros.errors import ZrosError


def Message(type_name: str | type[_MessageBase], **fields: Any) -> _MessageBase:  # noqa: N802
    """A new message of a ROS type with its default values (rosR: ``ros.Message``).

    >>> import zros
    >>> zros.Message('std_msgs/msg/String', data='hello').data
    'hello'
    """
    from zros.cdr import new_message

    return new_message(type_name, **fields)


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        module, attribute = _LAZY[name]
        value = getattr(importlib.import_module(module), attribute)
        globals()[name] = value
        return value
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])


__all__ = [
    'CdrError',
    'InterfaceSyntaxError',
    'Message',
    'UnknownTypeError',
    'ZrosError',
    'get_type',
    'register_type',
    'type_hash',
]
