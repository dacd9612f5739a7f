"""Bridge to pycdr2: zros message types as pycdr2 ``IdlStruct`` classes, and conversions.

pycdr2 is optional; it is imported on first use. The classes it builds encode plain CDR (XCDR1,
final extensibility) exactly as ROS 2 does::

    >>> from zros.cdr.pycdr2 import pycdr2_class, to_pycdr2, from_pycdr2
    >>> Point = pycdr2_class('geometry_msgs/msg/Point')
    >>> Point.__idl_typename__
    'geometry_msgs::msg::dds_::Point_'

Mapping: ``bool`` -> ``bool``; ``byte``, ``char`` -> ``uint8`` (pycdr2's ``char`` is a
one-character str); other primitives -> the pycdr2 type of the same name; ``string`` -> ``str``,
``string<=N`` -> ``bounded_str[N]``; nested types -> their pycdr2 class; ``T[N]`` ->
``array[T, N]``; ``T[<=N]`` -> ``sequence[T, N]``; ``T[]`` -> ``sequence[T]``. ``wstring`` has no
ROS-compatible pycdr2 type and raises NotImplementedError. An empty message gets the member
``structure_needs_at_least_one_member: uint8``, the placeholder byte ROS puts on the wire.

Values: pycdr2 holds arrays of ``uint8`` (also ``byte`` and ``char``) as ``bytes`` and every other
array or sequence as a list; :func:`to_pycdr2` gives the same types as pycdr2's own decoder.
"""

from __future__ import annotations

import threading
import weakref
from types import ModuleType
from typing import Protocol

import numpy as np

from zros.cdr.layout import VALUE_CODES
from zros.cdr.message import Message
from zros.cdr.model import FieldType, Kind, MessageDef
from zros.cdr.naming import attribute_name
from zros.cdr.registry import TypeRegistry, default_registry, registry_of
from zros.cdr.typestore import PLACEHOLDER_FIELD

TypeLike = str | type[Message]

#: pycdr2 limits the bound of ``sequence[T, N]`` to this; larger bounds become unbounded.
_MAX_SEQUENCE_BOUND = 65535
_BYTE_TYPES = ('byte', 'char', 'uint8')

_lock = threading.RLock()
#: registry -> full type name -> (definition the class was built from, pycdr2 class)
_cache: weakref.WeakKeyDictionary[TypeRegistry, dict[str, tuple[MessageDef, type]]] = (
    weakref.WeakKeyDictionary()
)
#: pycdr2 class -> (registry, full type name), to find the zros type in from_pycdr2
_origins: weakref.WeakKeyDictionary[type, tuple[weakref.ref[TypeRegistry], str]] = (
    weakref.WeakKeyDictionary()
)


def _pycdr2() -> ModuleType:
    """The pycdr2 module, or ImportError with install instructions."""
    try:
        import pycdr2  # noqa: PLC0415 (optional: pycdr2)
        import pycdr2.types  # noqa: PLC0415 (optional: pycdr2)
    except ImportError as exc:
        raise ImportError(
            'zros.cdr.pycdr2 needs the optional pycdr2 package: pip install pycdr2'
        ) from exc
    return pycdr2


def _resolve(type_or_name: TypeLike, registry: TypeRegistry | None) -> tuple[TypeRegistry, str]:
    """The registry and full message name of a class or any accepted spelling of a name."""
    if isinstance(type_or_name, type):
        chosen = registry if registry is not None else registry_of(type_or_name)
        return chosen, type_or_name.__msgtype__
    chosen = registry if registry is not None else default_registry()
    return chosen, chosen.message_definition(type_or_name).name


def dds_type_name(name: str) -> str:
    """The DDS type name ROS uses for a message: ``pkg::msg::dds_::Name_``."""
    package, kind, short = name.split('/')
    return f'{package}::{kind}::dds_::{short}_'


def pycdr2_class(type_or_name: TypeLike, registry: TypeRegistry | None = None) -> type:
    """The pycdr2 IdlStruct class of a zros type (cached per registry and name)."""
    _pycdr2()
    chosen, name = _resolve(type_or_name, registry)
    with _lock:
        return _build(chosen, name)


def _build(registry: TypeRegistry, name: str) -> type:
    definition = registry.message_definition(name)
    per_registry = _cache.setdefault(registry, {})
    cached = per_registry.get(definition.name)
    if cached is not None and cached[0] is definition:
        return cached[1]
    pycdr2 = _pycdr2()
    fields: dict[str, object] = {}
    for f in definition.fields:
        fields[attribute_name(f.name)] = _annotation(registry, definition.name, f.name, f.type)
    if not fields:
        fields[PLACEHOLDER_FIELD] = pycdr2.types.uint8
    package, kind, short = definition.name.split('/')
    cls: type = pycdr2.make_idl_struct(short, dds_type_name(definition.name), fields)
    cls.__module__ = f'zros.pycdr2.{package}.{kind}'  # for reprs only: no annotation is a string
    per_registry[definition.name] = (definition, cls)
    _origins[cls] = (weakref.ref(registry), definition.name)
    return cls


class _Generic(Protocol):
    """pycdr2's array, sequence and bounded_str: subscripted to make annotations."""

    def __getitem__(self, key: object, /) -> object: ...


def _subscript(generic: _Generic, *args: object) -> object:
    """``generic[args]`` for pycdr2's array, sequence and bounded_str."""
    return generic[args if len(args) > 1 else args[0]]


def _annotation(registry: TypeRegistry, owner: str, field: str, ftype: FieldType) -> object:
    """The pycdr2 annotation of one field."""
    types = _pycdr2().types
    element: object
    if ftype.base == 'wstring':
        raise NotImplementedError(
            f'{owner} field {field!r}: wstring has no ROS-compatible pycdr2 type'
        )
    if ftype.base == 'string':
        element = _subscript(types.bounded_str, ftype.string_bound) if ftype.string_bound else str
    elif ftype.base == 'bool':
        element = bool
    elif ftype.base in _BYTE_TYPES:
        element = types.uint8
    elif ftype.is_primitive:
        element = getattr(types, ftype.base)
    else:
        element = _build(registry, ftype.base)
    if ftype.kind is Kind.SCALAR:
        return element
    if ftype.kind is Kind.ARRAY:
        return _subscript(types.array, element, ftype.length)
    if ftype.kind is Kind.BOUNDED and ftype.length <= _MAX_SEQUENCE_BOUND:
        return _subscript(types.sequence, element, ftype.length)
    # pycdr2 rejects larger bounds (sequence[T, N] gives a TypeError object): leave it unbounded
    return _subscript(types.sequence, element)


# --- conversions ----------------------------------------------------------------------------


def to_pycdr2(message: Message) -> object:
    """A pycdr2 instance of ``pycdr2_class(type(message))`` with equal content."""
    _pycdr2()
    cls = type(message)
    return _Converter(registry_of(cls)).to(cls.__msgtype__, message)


def from_pycdr2(
    obj: object, type_or_name: TypeLike | None = None, registry: TypeRegistry | None = None
) -> Message:
    """The zros message with the content of a pycdr2 instance.

    Without ``type_or_name`` the type is the one ``obj``'s class was built for by
    :func:`pycdr2_class`, else it is read from the class's DDS type name.
    """
    if type_or_name is None:
        origin = _origins.get(type(obj))
        known = origin[0]() if origin is not None else None
        if origin is not None and known is not None and registry in (None, known):
            chosen, name = known, origin[1]
        else:
            typename: str = getattr(type(obj), '__idl_typename__', type(obj).__name__)
            chosen, name = _resolve(typename.replace('.', '::'), registry)
    else:
        chosen, name = _resolve(type_or_name, registry)
    _pycdr2()
    return _Converter(chosen).from_(name, obj)


_Fields = tuple[tuple[str, FieldType], ...]


class _Converter:
    """Converts the values of one registry's types, remembering the classes of each type."""

    def __init__(self, registry: TypeRegistry) -> None:
        self.registry = registry
        self._types: dict[str, tuple[type, type[Message], _Fields]] = {}

    def _type(self, name: str) -> tuple[type, type[Message], _Fields]:
        found = self._types.get(name)
        if found is None:
            definition = self.registry.message_definition(name)
            with _lock:
                target = _build(self.registry, name)
            fields = tuple((attribute_name(f.name), f.type) for f in definition.fields)
            found = (target, self.registry.get_class(name), fields)
            self._types[name] = found
        return found

    def to(self, name: str, message: Message) -> object:
        target, _, fields = self._type(name)
        if not fields:
            return target(**{PLACEHOLDER_FIELD: 0})
        return target(**{attr: self.to_field(t, message, attr) for attr, t in fields})

    def to_field(self, ftype: FieldType, message: Message, attr: str) -> object:
        # a field of a message whose class is built at run time: its value's type is ftype's
        value = getattr(message, attr)
        if ftype.kind is Kind.SCALAR:
            if ftype.is_nested:
                return self.to(ftype.base, value)
            return value.item() if isinstance(value, np.generic) else value
        if ftype.is_primitive:
            array = np.asarray(value, dtype=VALUE_CODES[ftype.base])
            if ftype.kind is Kind.ARRAY and ftype.base in _BYTE_TYPES:
                # pycdr2 writes array[uint8, N] from bytes, and decodes it to bytes
                return array.tobytes()
            return array.tolist()
        if ftype.is_string:
            return list(value)
        # lists of messages and StructSeqs alike iterate over message objects
        return [self.to(ftype.base, item) for item in value]

    def from_(self, name: str, obj: object) -> Message:
        _, cls, fields = self._type(name)
        return cls(**{attr: self.from_field(t, obj, attr) for attr, t in fields})

    def from_field(self, ftype: FieldType, obj: object, attr: str) -> object:
        # a field of a pycdr2 object, whose class is built at run time: its type is ftype's
        value = getattr(obj, attr)
        if ftype.kind is Kind.SCALAR:
            return self.from_(ftype.base, value) if ftype.is_nested else value
        if ftype.is_primitive:
            dtype = np.dtype(VALUE_CODES[ftype.base])
            if isinstance(value, (bytes, bytearray, memoryview)):
                return np.frombuffer(value, dtype).copy()
            return np.array(value, dtype=dtype)
        if ftype.is_string:
            return list(value)
        # a list of messages; the constructor makes a StructSeq where the field type needs one
        return [self.from_(ftype.base, item) for item in value]


__all__ = ['dds_type_name', 'from_pycdr2', 'pycdr2_class', 'to_pycdr2']
