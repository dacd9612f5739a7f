"""Sequences of fixed-size structs, backed by one numpy structured array.

Sequences of *uniform* structs (``zros.cdr.layout``) decode to a :class:`StructSeq`: a view of
the received bytes, turned into message objects on first indexing or iteration.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, MutableSequence
from typing import TYPE_CHECKING, TypeVar, overload

import numpy as np

from zros.cdr.arrays import Array
from zros.cdr.convert import Bad, Where, message_list
from zros.cdr.message import Message

M = TypeVar('M', bound=Message)
if TYPE_CHECKING:  # slice is not subscriptable at run time before Python 3.14
    Slice = slice[int | None, int | None, int | None]


class StructSeq(MutableSequence[M]):
    """A sequence of messages of one fixed-size type, backed by a numpy structured array.

    Decoding gives a zero-copy view of the received bytes. ``.array`` is the structured array
    (for vectorised math: ``poses.array['position']['x']``); indexing, iterating or changing the
    sequence works with message objects, made from the array on first use. After that ``.array``
    packs the objects back into a new array. Hold on to ``.array`` or to element objects, not to
    both at once.
    """

    __slots__ = ('_arr', '_cls', '_items')

    def __init__(self, cls: type[M], data: Iterable[M] | Array | None = None) -> None:
        self._cls = cls
        self._arr: Array | None = None
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
    def _from_array(cls, element: type[M], array: Array) -> StructSeq[M]:
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
            make = self._cls._from_tuple  # type: ignore[attr-defined]  # generated for uniform structs
            self._items = [make(row) for row in rows]
            self._arr = None
        return self._items

    @property
    def array(self) -> Array:
        """The elements as a numpy structured array laid out as on the wire."""
        if self._arr is None:
            self._arr = pack_structs(self._cls, self._items or [])
            self._items = None
        return self._arr

    @array.setter
    def array(self, value: Array) -> None:
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
        return len(self._arr) if self._items is None else len(self._items)  # type: ignore[arg-type]  # one of them is set

    @overload
    def __getitem__(self, index: int) -> M: ...

    @overload
    def __getitem__(self, index: Slice) -> list[M]: ...

    def __getitem__(self, index: int | Slice) -> M | list[M]:
        return self._list()[index]

    @overload
    def __setitem__(self, index: int, value: M) -> None: ...

    @overload
    def __setitem__(self, index: Slice, value: Iterable[M]) -> None: ...

    def __setitem__(self, index: int | Slice, value: M | Iterable[M]) -> None:
        self._list()[index] = value  # type: ignore[index,assignment]  # the overloads pair them

    def __delitem__(self, index: int | Slice) -> None:
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

    __hash__ = None  # type: ignore[assignment]  # sequences are mutable

    def __repr__(self) -> str:
        content = repr(self._arr) if self._arr is not None else repr(self._items)
        return f'StructSeq({self._cls.__msgtype__}, {content})'

    def copy(self) -> StructSeq[M]:
        """A deep copy (a writable array, or copies of the element objects)."""
        if self._arr is not None:
            return StructSeq._from_array(self._cls, self._arr.copy())
        return StructSeq(self._cls, [item.copy() for item in self._items or []])


def pack_structs(cls: type[Message], items: Iterable[object], writable: bool = True) -> Array:
    """A structured array of ``cls._dtype`` from message objects (or dicts)."""
    dtype = cls._dtype
    assert dtype is not None
    if isinstance(items, list) and (data := _fast_rows(cls, items)) is not None:
        return np.frombuffer(bytearray(data) if writable else data, dtype)
    rows = []
    to_tuple = cls._to_tuple  # type: ignore[attr-defined]  # generated for uniform structs
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


def struct_rows(
    value: StructSeq[Message] | Array | Iterable[Message], cls: type[Message], bound: int
) -> tuple[int, bytes | Array]:
    """The element count and what to encode of a struct sequence field. A sequence of message
    objects is packed row by row into bytes (building an array for a few elements cost more
    than packing them); arrays, and elements the packer refuses, go through
    :func:`struct_array`."""
    if type(value) is StructSeq and value._arr is None:
        items: object = value._items or []
    else:
        items = value
    if type(items) is list and getattr(cls, '_pack_rows', None) is not None:
        if not items:
            return 0, b''
        if bound >= 0 and len(items) > bound:
            raise Bad(f'{len(items)} elements exceed the bound of {bound}')
        if (data := _fast_rows(cls, items)) is not None:
            return len(items), data
    array = struct_array(value, cls, bound)
    return len(array), array


def _fast_rows(cls: type[Message], items: list[object]) -> bytes | None:
    """``items`` packed row by row by the class's generated packer, or None when it has none
    or refuses an element (a wrong one, or a dict): the checked path then says which."""
    fast = getattr(cls, '_pack_rows', None)
    if fast is None:
        return None
    try:
        data: bytes = fast(items)
    except Exception:
        return None
    return data


def struct_array(
    value: StructSeq[Message] | Array | Iterable[Message], cls: type[Message], bound: int
) -> Array:
    """The contiguous little-endian structured array to encode for a struct sequence field."""
    dtype = cls._dtype
    assert dtype is not None
    array: Array
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


def struct_items(cls: type[Message], value: object, bound: int, where: Where) -> object:
    """The constructor argument of a struct sequence field: arrays and StructSeqs as they are,
    else a checked list of messages."""
    if isinstance(value, (np.ndarray, StructSeq)):
        return value
    return message_list(cls, value, (-1, bound), where)
