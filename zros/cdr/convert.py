"""Value conversions used by generated message classes and codecs."""

from __future__ import annotations

import numbers
import operator
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from zros.cdr.arrays import Array, DType
from zros.cdr.errors import FieldError
from zros.cdr.model import INTEGER_RANGES, Buffer

if TYPE_CHECKING:
    from zros.cdr.message import Message


class Bad(Exception):
    """Internal signal of malformed input; the traced codec turns it into a CdrError."""


def _kind_name(kind: str) -> str:
    return {'f': 'floats', 'i': 'integers', 'u': 'integers', 'b': 'bools'}.get(kind, 'values')


def to_array(value: object, dtype: DType) -> Array:
    """A contiguous 1-D array of ``dtype`` from any sequence, refusing lossy conversions."""
    if type(value) is np.ndarray and value.dtype == dtype and value.ndim == 1:
        return value if value.flags.c_contiguous else np.ascontiguousarray(value)
    if (
        dtype.itemsize == 1
        and dtype.kind == 'u'
        and isinstance(value, (bytes, bytearray, memoryview))
    ):
        return np.frombuffer(value, np.uint8)
    if isinstance(value, (str, bytes)):
        raise TypeError(
            f'expected a sequence of {_kind_name(dtype.kind)}, got {type(value).__name__}'
        )
    array = np.asarray(value)
    if array.ndim != 1:
        if array.ndim == 0:
            raise TypeError(
                f'expected a sequence of {_kind_name(dtype.kind)}, got {type(value).__name__}'
            )
        raise ValueError(f'expected a 1-D sequence, got an array of shape {array.shape}')
    if array.dtype == dtype:
        return np.ascontiguousarray(array)
    if array.size == 0:
        return np.zeros(0, dtype)
    source = array.dtype.kind
    target = dtype.kind
    if target == 'f':
        if source not in 'fiub':
            raise TypeError(f'expected numbers, got {array.dtype} values')
    elif target in 'iu':
        if source not in 'iub':
            raise TypeError(f'expected integers, got {array.dtype} values')
        info = np.iinfo(dtype)
        low, high = array.min(), array.max()
        if low < info.min or high > info.max:
            bad = low if low < info.min else high
            raise ValueError(
                f'value {bad} is out of the range of {dtype.name} [{info.min}, {info.max}]'
            )
    elif target == 'b':
        if source == 'b' or (source in 'iu' and ((array == 0) | (array == 1)).all()):
            pass
        else:
            raise TypeError(f'expected bools, got {array.dtype} values')
    return np.ascontiguousarray(array.astype(dtype))


def prim_array(value: object, dtype: DType, bound: int) -> Array:
    """An array for a sequence field, checked against its bound (-1: unbounded)."""
    if (
        type(value) is np.ndarray
        and value.dtype == dtype
        and value.ndim == 1
        and value.flags.c_contiguous
    ):
        array = value
    else:
        array = to_array(value, dtype)
    if bound >= 0 and len(array) > bound:
        raise Bad(f'{len(array)} elements exceed the bound of {bound}')
    return array


def fixed_array(value: object, dtype: DType, count: int) -> Array:
    """An array for a fixed-size array field; its length must be exactly ``count``."""
    if (
        type(value) is np.ndarray
        and value.dtype == dtype
        and value.ndim == 1
        and value.flags.c_contiguous
    ):
        array = value
    else:
        array = to_array(value, dtype)
    if len(array) != count:
        raise Bad(f'expected exactly {count} elements, got {len(array)}')
    return array


#: (message type, field path): where a constructor argument goes, for errors
Where = tuple[str, str]
#: (count of a fixed array or -1, bound of a bounded sequence or -1)
Shape = tuple[int, int]


def init_array(value: object, dtype: DType, shape: Shape, where: Where) -> Array:
    """Convert a constructor argument for an array field, with the field name in errors."""
    try:
        array = to_array(value, dtype)
    except (TypeError, ValueError, OverflowError) as exc:
        raise FieldError(*where, str(exc)) from None
    _check_length(len(array), shape, where)
    return array


def _check_length(size: int, shape: Shape, where: Where) -> None:
    count, bound = shape
    if count >= 0 and size != count:
        raise FieldError(*where, f'expected exactly {count} elements, got {size}')
    if bound >= 0 and size > bound:
        raise FieldError(*where, f'{size} elements exceed the bound of {bound}')


# --- constructor checks: called only when the generated fast check fails ------------------------


def _shown(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + '...'


def _wrong(where: Where, expected: str, value: object) -> FieldError:
    return FieldError(*where, f'expected {expected}, got {type(value).__name__} {_shown(value)}')


def scalar(value: object, primitive: str, bound: int, where: Where) -> float | bool | str:
    """The value a scalar field keeps for a constructor argument, or a FieldError.

    Floats take any real number but bools; integers take ints, numpy integers and bools, in range
    (``byte`` also one byte, ``char`` one character); bools take bools and 0 or 1; strings take
    str (``bound``: at most that many bytes in UTF-8).
    """
    if primitive in ('float32', 'float64'):
        if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
            return float(value)
        raise _wrong(where, f'a float for {primitive}', value)
    if primitive == 'bool':
        if isinstance(value, (bool, np.bool_)) or (
            isinstance(value, numbers.Integral) and value in (0, 1)
        ):
            return bool(value)
        raise _wrong(where, 'a bool (true or false)', value)
    if primitive in ('string', 'wstring'):
        if not isinstance(value, str):
            raise _wrong(where, f'a str for {primitive}', value)
        if bound and len(value.encode()) > bound:
            raise FieldError(*where, f'{_shown(value)} exceeds the bound of {bound} bytes')
        return str(value)
    if primitive in ('byte', 'char') and isinstance(value, (bytes, str)) and len(value) == 1:
        value = ord(value)
    elif isinstance(value, (float, np.floating)) or not hasattr(value, '__index__'):
        raise _wrong(where, f'an int for {primitive}', value)
    number = operator.index(value)
    low, high = INTEGER_RANGES[primitive]
    if not low <= number <= high:
        raise FieldError(*where, f'{number} is out of the range of {primitive} [{low}, {high}]')
    return int(number)


def message(cls: type[Message], value: object, where: Where) -> object:
    """A nested message field from a constructor argument: a message of its type or a dict."""
    if isinstance(value, Mapping):
        try:
            return cls.from_dict(value)
        except FieldError as exc:
            raise exc.inside(*where) from None
    if not isinstance(value, type) and getattr(value, '__msgtype__', None) == cls.__msgtype__:
        return value  # the same type from another registry (a bag's own definitions)
    raise _wrong(where, f'a {cls.__msgtype__} or a dict', value)


def _items(value: object, what: str, where: Where) -> list[object]:
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Iterable):
        raise _wrong(where, f'a list of {what}', value)
    return list(value)


def message_list(cls: type[Message], value: object, shape: Shape, where: Where) -> list[object]:
    """A list of nested messages from a constructor argument (messages or dicts)."""
    items = _items(value, cls.__msgtype__, where)
    type_name, name = where
    for index, item in enumerate(items):
        if type(item) is not cls:
            items[index] = message(cls, item, (type_name, f'{name}[{index}]'))
    _check_length(len(items), shape, where)
    return items


def string_list(
    value: object, primitive: str, string_bound: int, shape: Shape, where: Where
) -> list[str]:
    """A list of strings from a constructor argument."""
    items = _items(value, 'str', where)
    type_name, name = where
    for index, item in enumerate(items):
        if type(item) is not str or (string_bound and len(item) > string_bound):
            items[index] = scalar(item, primitive, string_bound, (type_name, f'{name}[{index}]'))
    _check_length(len(items), shape, where)
    return items  # type: ignore[return-value]  # each item is a str now (made one above)


def empty_array(dtype: DType) -> Array:
    """A shared, read-only empty array (decoded empty sequences all use it)."""
    array = np.zeros(0, dtype)
    array.flags.writeable = False
    return array


# --- wstring: a u32 count of UTF-16 code units, each written as a 4-byte wchar_t --------------


def wstring_encode(value: str) -> tuple[bytes, int]:
    """The wire bytes (without the count) of a wstring, and its count of code units."""
    if type(value) is not str:
        raise TypeError(f'expected str, got {type(value).__name__}')
    units = np.frombuffer(value.encode('utf-16-le'), '<u2')
    return units.astype('<u4').tobytes(), len(units)


def wstring_decode(buf: Buffer, pos: int, count: int, end: int, endian: str) -> tuple[str, int]:
    """Decode ``count`` 4-byte code units at ``pos``; returns the text and the next offset."""
    stop = pos + 4 * count
    if stop > end:
        raise Bad(f'wstring of {count} characters runs past the end of the buffer ({end} bytes)')
    units = np.frombuffer(buf, endian + 'u4', count, pos)
    if count and units.max() > 0xFFFF:
        raise Bad('wstring holds a code unit above 0xFFFF')
    try:
        text = units.astype('<u2').tobytes().decode('utf-16-le')
    except UnicodeDecodeError as exc:
        raise Bad(f'wstring is not valid UTF-16: {exc.reason}') from None
    return text, stop


def check_scalar(primitive: str, value: object, low: int | None, high: int | None) -> None:
    """Explain why a scalar value cannot be encoded (used by the traced encoder only)."""
    if primitive in ('float32', 'float64'):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
            raise Bad(f'expected a float for {primitive}, got {type(value).__name__} {value!r}')
        if (
            primitive == 'float32'
            and abs(float(value)) > 3.4028234663852886e38
            and np.isfinite(value)
        ):
            raise Bad(f'{value!r} is too large for float32')
        return
    if primitive == 'bool':
        return
    if isinstance(value, (float, np.floating)) or not hasattr(value, '__index__'):
        raise Bad(f'expected an int for {primitive}, got {type(value).__name__} {value!r}')
    number = int(value)
    if low is not None and high is not None and not low <= number <= high:
        raise Bad(f'{number} is out of the range of {primitive} [{low}, {high}]')
