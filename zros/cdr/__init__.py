"""ROS interface definitions, generated message classes and the CDR codec.

>>> from zros import cdr
>>> Twist = cdr.get_type('geometry_msgs/msg/Twist')
>>> data = cdr.encode(Twist(linear={'x': 1.0}))
>>> cdr.decode('geometry_msgs/msg/Twist', data).linear.x
1.0
"""

from __future__ import annotations

from zros.cdr import registry as _registry
from zros.cdr.errors import (
    CdrError,
    FieldError,
    InterfaceSyntaxError,
    TypeNameError,
    UnknownTypeError,
)
from zros.cdr.hashing import type_hash as _type_hash
from zros.cdr.interfaces import ActionType, ServiceType
from zros.cdr.message import Message, decode_failure, definition_of, encode
from zros.cdr.message import decode as _decode
from zros.cdr.model import (
    ActionDef,
    Definition,
    JsonValue,
    MessageDef,
    ServiceDef,
)
from zros.cdr.registry import TypeRegistry, default_registry, set_default_registry
from zros.cdr.struct_seq import StructSeq
from zros.deprecation import deprecated

TypeLike = str | type[Message]

_classes: dict[str, type[Message]] = {}


def get_class(type_name: TypeLike) -> type[Message]:
    """The message class of a type name (``pkg/msg/Name``, ``pkg/Name``...) or class."""
    if isinstance(type_name, type):
        return type_name
    cls = _classes.get(type_name)
    if cls is None or cls._registry is not default_registry():
        cls = default_registry().get_class(type_name)
        _classes[type_name] = cls
    return cls


def get_type(type_name: TypeLike) -> type[Message] | ServiceType | ActionType:
    """A message class, or a service or action type, from any accepted spelling of its name."""
    return default_registry().get_type(type_name)


def new_message(type_name: TypeLike, **fields: object) -> Message:
    """A message of the given type with ROS default values, updated with ``fields``."""
    return get_class(type_name)(**fields)


def decode(
    type_name: TypeLike, buf: bytes | bytearray | memoryview, strict: bool = False
) -> Message:
    """Decode CDR bytes (4-byte header included) into a message of the given type.

    Trailing bytes are ignored unless ``strict``, which allows at most 3 (alignment padding).
    """
    if type(type_name) is not str:
        return _decode_other(type_name, buf, strict)
    try:  # a name decoded before: one dict look-up and the compiled decoder
        return _registry.default_decoders[type_name](buf, strict)
    except Exception:
        return _decode_first(type_name, buf, strict)


def _decode_other(type_name: object, buf: bytes | bytearray | memoryview, strict: bool) -> Message:
    """:func:`decode` given a message class (or a subclass of ``str``)."""
    if isinstance(type_name, type) and issubclass(type_name, Message):
        return _decode(type_name, buf, strict)
    if isinstance(type_name, str):
        return _decode_first(str(type_name), buf, strict)
    kind = type(type_name).__name__
    raise TypeError(f'decode takes a type name or a message class, not {kind}')


def _decode_first(type_name: str, buf: bytes | bytearray | memoryview, strict: bool) -> Message:
    """:func:`decode` of a name not decoded before, or of malformed data."""
    decoder = default_registry().decoder(type_name)
    try:
        return decoder(buf, strict)
    except Exception as exc:
        raise decode_failure(get_class(type_name), buf, strict, exc) from None


def __getattr__(name: str) -> object:
    if name in ('Untyped', 'FieldValue'):  # were aliases of Any
        deprecated(f'zros.cdr.{name}', 'object, or a Protocol of what is used')
        return object
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


def register_type(type_name: str, text: str) -> Definition:
    """Register .msg, .srv or .action text for a type name in the default registry."""
    return default_registry().register_text(type_name, text)


def type_hash(type_name: TypeLike) -> str:
    """The RIHS01 type hash of a message, service or action type."""
    name = type_name.__msgtype__ if isinstance(type_name, type) else type_name
    return _type_hash(default_registry(), name)


__all__ = [
    'ActionDef',
    'ActionType',
    'CdrError',
    'Definition',
    'FieldError',
    'InterfaceSyntaxError',
    'JsonValue',
    'Message',
    'MessageDef',
    'ServiceDef',
    'ServiceType',
    'StructSeq',
    'TypeNameError',
    'TypeRegistry',
    'UnknownTypeError',
    'decode',
    'default_registry',
    'definition_of',
    'encode',
    'get_class',
    'get_type',
    'new_message',
    'register_type',
    'set_default_registry',
    'type_hash',
]
