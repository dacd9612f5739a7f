"""Generated message classes and the sequence type for fixed-size structs.

Every ROS message type becomes a subclass of :class:`Message` with ``__slots__``, ROS default
values, ``==``, a readable ``repr``, ``copy``, ``to_dict``/``from_dict`` and its CDR codec. The
codec is generated on first use.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, MutableSequence
from typing import TYPE_CHECKING, Any, ClassVar, TypeVar, overload

import numpy as np

from zros.cdr import codegen
from zros.cdr.convert import Bad
from zros.cdr.errors import CdrError, FieldError
from zros.cdr.layout import LayoutCache, StructInfo
from zros.cdr.model import MessageDef
from zros.cdr.naming import attribute_name

if TYPE_CHECKING:
    from typing_extensions import Self

    from zros.cdr.registry import TypeRegistry

M = TypeVar('M', bound='Message')


class Message:
    """Base class of all generated message classes."""

    __slots__ = ()
    __hash__ = None  # type: ignore[assignment]  # messages are mutable

    __msgtype__: ClassVar[str]
    #: attribute names, in field order
    _fields: ClassVar[tuple[str, ...]] = ()
    #: attribute name -> field type as written in .msg files
    _field_types: ClassVar[dict[str, str]] = {}
    _definition: ClassVar[MessageDef]
    _registry: ClassVar[TypeRegistry]
    #: numpy dtype of one element when a sequence of this type is a structured array, else None
    _dtype: ClassVar[np.dtype | None] = None

    if TYPE_CHECKING:
        # fields are generated at run time: to type checkers every field is Any
        def __getattr__(self, name: str) -> Any: ...

        def __setattr__(self, name: str, value: Any) -> None: ...

    # generated per class
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        raise TypeError('Message is abstract; use zros.Message(type) or a generated class')

    def copy(self) -> Self:
        """A deep copy; its arrays are writable even where this message's are views."""
        raise NotImplementedError

    def to_dict(self) -> dict[str, Any]:
        """Nested dicts and lists of plain Python values (YAML and JSON friendly)."""
        raise NotImplementedError

    @staticmethod
    def _cdr_encode(message: Any, join: Any = None) -> bytes:
        raise NotImplementedError

    @staticmethod
    def _cdr_decode(buf: Any, strict: bool = False) -> Any:
        raise NotImplementedError

    # common API

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Self:
        """Build a message from nested dicts, as ``to_dict`` returns them.

        Missing fields keep their defaults. Keys may be ROS names or attribute names (``from`` or
        ``from_``). An unknown key, or a value its field cannot hold, raises a
        :class:`~zros.cdr.errors.FieldError` naming the field's path.
        """
        if not isinstance(data, Mapping):
            raise TypeError(
                f'{cls.__msgtype__}.from_dict needs a mapping, got {type(data).__name__}'
            )
        names = {f.name: attribute_name(f.name) for f in cls._definition.fields}
        attributes = set(names.values())
        for key in data:
            if key not in names and key not in attributes:
                raise FieldError.unknown(cls.__msgtype__, str(key), tuple(names))
        return cls(**{names.get(key, key): value for key, value in data.items()})

    def serialize(self) -> bytes:
        """CDR bytes of this message (little-endian, with the 4-byte header)."""
        return encode(self)

    @classmethod
    def deserialize(cls, buf: bytes | bytearray | memoryview, strict: bool = False) -> Self:
        """Decode CDR bytes (header included) into a message of this type."""
        return decode(cls, buf, strict)

    @classmethod
    def get_fields_and_field_types(cls) -> dict[str, str]:
        """Field names and their ROS types, as rclpy messages offer them."""
        return dict(cls._field_types)

    def __copy__(self) -> Self:
        return self.copy()

    def __deepcopy__(self, memo: dict[int, Any]) -> Self:
        return self.copy()

    def __reduce__(self) -> tuple[Any, tuple[str, bytes]]:
        return (_unpickle, (self.__msgtype__, encode(self)))


def _unpickle(type_name: str, data: bytes) -> Message:
    from zros.cdr.registry import default_registry

    return decode(default_registry().get_class(type_name), data)


# --- encode / decode entry points -----------------------------------------------------------


def encode(message: Message) -> bytes:
    """CDR bytes of a message: the 4-byte little-endian header, then the body, no padding."""
    try:
        return message._cdr_encode(message)
    except CdrError:
        raise
    except Exception:
        if not isinstance(message, Message):
            raise TypeError(f'expected a zros message, got {type(message).__name__}') from None
        raise _explain_encode(type(message), message) from None


def decode(cls: type[M], buf: bytes | bytearray | memoryview, strict: bool = False) -> M:
    """Decode CDR bytes (header included) into a message of class ``cls``.

    Arrays of the result are views into ``buf`` (read-only when ``buf`` is ``bytes``). Bytes
    after the message are ignored, as DDS readers ignore them; ``strict=True`` allows at most 3
    (alignment padding), which tells whether the data really is of this type.
    """
    try:
        return cls._cdr_decode(buf, strict)  # type: ignore[no-any-return]
    except CdrError:
        raise
    except Exception:
        raise _explain_decode(cls, buf, strict) from None


def _explain_encode(cls: type[Message], message: Message) -> CdrError:
    traced = _codecs(cls).traced_encoder()
    try:
        traced(message)
    except CdrError as exc:
        return exc
    return CdrError(f'cannot encode {cls.__msgtype__}', type_name=cls.__msgtype__)


def _explain_decode(cls: type[Message], buf: Any, strict: bool) -> CdrError:
    name = getattr(cls, '__msgtype__', '?')
    try:
        view = memoryview(buf)
    except TypeError:
        return CdrError(
            f'cannot decode {name}: expected bytes, bytearray or memoryview, '
            f'got {type(buf).__name__}',
            type_name=name,
        )
    if view.ndim != 1 or view.itemsize != 1:
        view = view.cast('B')
    size = len(view)
    if size < 4:
        return CdrError(
            f'cannot decode {name}: {size} bytes is shorter than the 4-byte CDR header',
            type_name=name,
            offset=0,
        )
    if view[0] != 0 or view[1] > 1:
        return CdrError(
            f'cannot decode {name}: unsupported encapsulation {bytes(view[:2]).hex()} '
            '(only plain CDR, 0000 big-endian or 0001 little-endian, is supported)',
            type_name=name,
            offset=0,
        )
    traced = _codecs(cls).traced_decoder('<' if view[1] else '>')
    try:
        traced(view, strict)
    except CdrError as exc:
        return exc
    return CdrError(f'cannot decode {name}', type_name=name)


# --- class construction ---------------------------------------------------------------------


class _Codecs:
    """Compiles the codec variants of one class on first use."""

    def __init__(self, registry: TypeRegistry, cls: type[Message], layout: LayoutCache) -> None:
        self.registry = registry
        self.cls = cls
        self.layout = layout
        self._traced: dict[str, Any] = {}

    # Context protocol for the generator
    def resolve(self, name: str) -> MessageDef:
        return self.registry.message_definition(name)

    def info(self, name: str) -> StructInfo:
        return self.layout.info(name)

    def cls_of(self, name: str) -> type:
        return self.registry.get_class(name)

    def dtype(self, name: str, endian: str) -> np.dtype:
        return self.layout.dtype(name, endian)

    def decoder(self, endian: str, memory: bool) -> Any:
        return codegen.generate_decoder(_Ctx(self), self.cls._definition, endian, memory, False)

    def encoder(self) -> Any:
        return codegen.generate_encoder(_Ctx(self), self.cls._definition, False)

    def traced_decoder(self, endian: str) -> Any:
        key = 'd' + endian
        if key not in self._traced:
            self._traced[key] = codegen.generate_decoder(
                _Ctx(self), self.cls._definition, endian, True, True
            )
        return self._traced[key]

    def traced_encoder(self) -> Any:
        if 'e' not in self._traced:
            self._traced['e'] = codegen.generate_encoder(_Ctx(self), self.cls._definition, True)
        return self._traced['e']


class _Ctx:
    def __init__(self, codecs: _Codecs) -> None:
        self._codecs = codecs

    def resolve(self, name: str) -> MessageDef:
        return self._codecs.resolve(name)

    def info(self, name: str) -> StructInfo:
        return self._codecs.info(name)

    def cls(self, name: str) -> type:
        return self._codecs.cls_of(name)

    def dtype(self, name: str, endian: str) -> np.dtype:
        return self._codecs.dtype(name, endian)


def _codecs(cls: type[Message]) -> _Codecs:
    return cls.__dict__['_zros_codecs']  # type: ignore[no-any-return]


def _install_lazy_codecs(cls: type[Message], codecs: _Codecs) -> None:
    """Give ``cls`` codec stubs that compile the real functions on their first call."""
    lock = codecs.registry._lock

    def decode_first(buf: Any, strict: bool = False) -> Any:
        with lock:
            if cls.__dict__['_cdr_decode'] is lazy_decode:
                little = codecs.decoder('<', False)
                variants: dict[str, Any] = {}

                def other(view: Any, strict: bool) -> Any:
                    # big-endian data, or text read from a memoryview: compile on demand
                    if type(view) is memoryview and (view.ndim != 1 or view.itemsize != 1):
                        view = view.cast('B')
                    if len(view) < 4 or view[0] or view[1] > 1:
                        raise Bad
                    key = ('m' if type(view) is memoryview else 'b') + ('<' if view[1] else '>')
                    if key not in variants:
                        variants[key] = codecs.decoder(key[1], key[0] == 'm')
                    return variants[key](view, strict)

                def fast(buf: Any, strict: bool = False) -> Any:
                    if type(buf) is memoryview or len(buf) < 4 or buf[0] or buf[1] != 1:
                        return other(buf, strict)
                    return little(buf, strict)

                cls._cdr_decode = staticmethod(fast)  # type: ignore[method-assign]
        return cls._cdr_decode(buf, strict)

    def encode_first(message: Any, join: Any = b''.join) -> bytes:
        with lock:
            if cls.__dict__['_cdr_encode'] is lazy_encode:
                cls._cdr_encode = staticmethod(codecs.encoder())  # type: ignore[method-assign]
        return cls._cdr_encode(message, join)

    lazy_decode = staticmethod(decode_first)
    lazy_encode = staticmethod(encode_first)
    cls._cdr_decode = lazy_decode  # type: ignore[method-assign]
    cls._cdr_encode = lazy_encode  # type: ignore[method-assign]


def _layout_of(registry: TypeRegistry) -> LayoutCache:
    cache: LayoutCache | None = getattr(registry, '_layout_cache', None)
    if cache is None:
        cache = LayoutCache(registry.message_definition)
        registry._layout_cache = cache  # type: ignore[attr-defined]
    return cache


def build_message_class(registry: TypeRegistry, definition: MessageDef) -> type[Message]:
    """Create the class of one message type (called by the registry, which caches it)."""
    package, kind, short = definition.name.split('/')
    attributes = tuple(attribute_name(f.name) for f in definition.fields)
    namespace: dict[str, Any] = {
        '__slots__': attributes,
        '__module__': f'zros.types.{package}.{kind}',
        '__qualname__': short,
        '__msgtype__': definition.name,
        '_fields': attributes,
        '_field_types': {attribute_name(f.name): str(f.type) for f in definition.fields},
        '_definition': definition,
        '_registry': registry,
        '__annotations__': {attribute_name(f.name): str(f.type) for f in definition.fields},
    }
    for constant in definition.constants:
        namespace[constant.name] = constant.value
    cls: type[Message] = type(short, (Message,), namespace)
    # the registry must hand out this class before nested references to it are generated
    registry._classes[definition.name] = cls
    layout = _layout_of(registry)
    codecs = _Codecs(registry, cls, layout)
    cls._zros_codecs = codecs  # type: ignore[attr-defined]
    for name, function in codegen.generate_methods(_Ctx(codecs), definition).items():
        setattr(cls, name, function)
    if layout.info(definition.name).uniform:
        cls._dtype = layout.dtype(definition.name, '<')
    _install_lazy_codecs(cls, codecs)
    return cls


# --- a reusable output buffer -------------------------------------------------------------------


class EncodeBuffer:
    """Assembles encoded parts into one bytearray reused from message to message.

    A fresh multi-megabyte object per message costs page faults and zeroing in the kernel, which
    halves the rate of a camera publisher. Messages under ``threshold`` bytes are joined into new
    ``bytes`` (faster for them). The result is valid until the next call: use it, then encode again.
    """

    __slots__ = ('_buffer', 'threshold')

    def __init__(self, threshold: int = 65536) -> None:
        self._buffer = bytearray()
        self.threshold = threshold

    def join(self, parts: list[Any]) -> bytes | bytearray:
        sizes = [part.nbytes if type(part) is np.ndarray else len(part) for part in parts]
        total = sum(sizes)
        if total < self.threshold:
            return b''.join(parts)
        buffer = self._buffer
        if len(buffer) < total:
            buffer = self._buffer = bytearray(total)
        elif len(buffer) > total:
            del buffer[total:]
        view = memoryview(buffer)
        try:
            offset = 0
            for part, size in zip(parts, sizes, strict=True):
                source: Any = part.view(np.uint8) if type(part) is np.ndarray else part
                view[offset : offset + size] = source
                offset += size
        finally:
            view.release()
        return buffer


# --- sequences of fixed-size structs ----------------------------------------------------------


class StructSeq(MutableSequence[M]):
    """A sequence of messages of one fixed-size type, backed by a numpy structured array.

    Decoding gives a zero-copy view of the received bytes. ``.array`` is the structured array
    (for vectorised math: ``poses.array['position']['x']``); indexing, iterating or changing the
    sequence works with message objects, made from the array on first use. After that ``.array``
    packs the objects back into a new array. Hold on to ``.array`` or to element objects, not to
    both at once.
    """

    __slots__ = ('_arr', '_cls', '_items')

    def __init__(self, cls: type[M], data: Iterable[M] | np.ndarray | None = None) -> None:
        self._cls = cls
        self._arr: np.ndarray | None = None
        self._items: list[M] | None = None
        if data is None:
            self._items = []
        elif isinstance(data, StructSeq):
            if data._arr is not None:
                self._arr = data._arr
            else:
                self._items = list(data._items or [])
        elif isinstance(data, np.ndarray):
            self.array = data
        else:
            items = list(data)
            for index, item in enumerate(items):
                if type(item) is dict:
                    items[index] = cls.from_dict(item)
            self._items = items

    @classmethod
    def _from_array(cls, element: type[M], array: np.ndarray) -> StructSeq[M]:
        seq: StructSeq[M] = object.__new__(cls)
        seq._cls = element
        seq._arr = array
        seq._items = None
        return seq

    @property
    def element_type(self) -> type[M]:
        """The message class of the elements."""
        return self._cls

    def _list(self) -> list[M]:
        if self._items is None:
            rows = self._arr.tolist() if self._arr is not None else []
            make = self._cls._from_tuple  # type: ignore[attr-defined]
            self._items = [make(row) for row in rows]
            self._arr = None
        return self._items

    @property
    def array(self) -> np.ndarray:
        """The elements as a numpy structured array laid out as on the wire."""
        if self._arr is None:
            self._arr = pack_structs(self._cls, self._items or [])
            self._items = None
        return self._arr

    @array.setter
    def array(self, value: np.ndarray) -> None:
        dtype = self._cls._dtype
        if dtype is None:
            raise TypeError(f'{self._cls.__msgtype__} has no structured array form')
        if not isinstance(value, np.ndarray) or value.ndim != 1 or value.dtype.names is None:
            raise TypeError(f'expected a 1-D structured array of {self._cls.__msgtype__}')
        if value.dtype != dtype:
            if value.dtype.names != dtype.names:
                raise TypeError(
                    f'array fields {value.dtype.names} do not match {self._cls.__msgtype__} '
                    f'fields {dtype.names}'
                )
            value = value.astype(dtype)
        self._arr = value
        self._items = None

    def __len__(self) -> int:
        return len(self._arr) if self._items is None else len(self._items)  # type: ignore[arg-type]

    @overload
    def __getitem__(self, index: int) -> M: ...

    @overload
    def __getitem__(self, index: slice) -> list[M]: ...

    def __getitem__(self, index: int | slice) -> M | list[M]:
        return self._list()[index]

    @overload
    def __setitem__(self, index: int, value: M) -> None: ...

    @overload
    def __setitem__(self, index: slice, value: Iterable[M]) -> None: ...

    def __setitem__(self, index: int | slice, value: Any) -> None:
        self._list()[index] = value

    def __delitem__(self, index: int | slice) -> None:
        del self._list()[index]

    def insert(self, index: int, value: M) -> None:
        """Insert a message at ``index`` (the sequence becomes a list of objects)."""
        self._list().insert(index, value)

    def __iter__(self) -> Iterator[M]:
        return iter(self._list())

    def __eq__(self, other: object) -> bool:
        if isinstance(other, StructSeq):
            if self._arr is not None and other._arr is not None:
                return bool(np.array_equal(self._arr, other._arr))
            return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))
        if isinstance(other, list):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        content = repr(self._arr) if self._arr is not None else repr(self._items)
        return f'StructSeq({self._cls.__msgtype__}, {content})'

    def copy(self) -> StructSeq[M]:
        """A deep copy (a writable array, or copies of the element objects)."""
        if self._arr is not None:
            return StructSeq._from_array(self._cls, self._arr.copy())
        return StructSeq(self._cls, [item.copy() for item in self._items or []])


def pack_structs(cls: type[Message], items: Iterable[Any], writable: bool = True) -> np.ndarray:
    """A structured array of ``cls._dtype`` from message objects (or dicts)."""
    dtype = cls._dtype
    assert dtype is not None
    fast = getattr(cls, '_pack_rows', None)
    if fast is not None and isinstance(items, list):
        try:
            data = fast(items)
        except Exception:  # a wrong element: the checked path below says which
            pass
        else:
            return np.frombuffer(bytearray(data) if writable else data, dtype)
    rows = []
    to_tuple = cls._to_tuple  # type: ignore[attr-defined]
    for index, item in enumerate(items):
        element = item
        if type(item) is not cls and getattr(item, '__msgtype__', None) != cls.__msgtype__:
            if not isinstance(item, Mapping):
                raise TypeError(
                    f'element {index}: expected {cls.__msgtype__}, got {type(item).__name__}'
                )
            element = cls.from_dict(item)
        rows.append(to_tuple(element))
    return np.array(rows, dtype=dtype)


def struct_array(value: Any, cls: type[Message], bound: int) -> np.ndarray:
    """The contiguous little-endian structured array to encode for a struct sequence field."""
    dtype = cls._dtype
    assert dtype is not None
    array: np.ndarray
    if type(value) is StructSeq:
        # never switch the sequence to array mode here: element objects the user holds must stay
        # part of the message
        if value._arr is not None:
            array = value._arr
        else:
            array = pack_structs(cls, value._items or [], False)
    elif isinstance(value, np.ndarray):
        array = value
    else:
        array = pack_structs(cls, value if isinstance(value, list) else list(value), False)
    if array.dtype != dtype:
        if array.dtype.names != dtype.names:
            raise TypeError(f'array fields do not match {cls.__msgtype__}')
        array = array.astype(dtype)
    if not array.flags.c_contiguous:
        array = np.ascontiguousarray(array)
    if bound >= 0 and len(array) > bound:
        raise Bad(f'{len(array)} elements exceed the bound of {bound}')
    return array


__all__ = ['Message', 'StructSeq', 'build_message_class', 'decode', 'encode']
