"""Parameter values: the nine ROS 2 types, Python values, and ``rcl_interfaces`` messages."""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, SupportsFloat, SupportsInt, TypeGuard

from zros.params.errors import ParameterError

if TYPE_CHECKING:
    from zros.cdr import Message

#: A parameter's value in its canonical form: bool, int, float, str, bytes or a list of one of
#: them, None when not set; ``ParameterType`` says which.
ParamValue = (
    bool | int | float | str | bytes | list[bool] | list[int] | list[float] | list[str] | None
)


class ParameterType(enum.IntEnum):
    """``rcl_interfaces/msg/ParameterType``."""

    NOT_SET = 0
    BOOL = 1
    INTEGER = 2
    DOUBLE = 3
    STRING = 4
    BYTE_ARRAY = 5
    BOOL_ARRAY = 6
    INTEGER_ARRAY = 7
    DOUBLE_ARRAY = 8
    STRING_ARRAY = 9

    @property
    def ros_name(self) -> str:
        """The name ROS 2 tools print: ``integer``, ``double_array``, ``not set``..."""
        return 'not set' if self is ParameterType.NOT_SET else self.name.lower()

    @property
    def is_array(self) -> bool:
        """Whether the type is one of the array types."""
        return self >= ParameterType.BYTE_ARRAY


#: the ParameterValue field holding each type
FIELDS = {
    ParameterType.BOOL: 'bool_value',
    ParameterType.INTEGER: 'integer_value',
    ParameterType.DOUBLE: 'double_value',
    ParameterType.STRING: 'string_value',
    ParameterType.BYTE_ARRAY: 'byte_array_value',
    ParameterType.BOOL_ARRAY: 'bool_array_value',
    ParameterType.INTEGER_ARRAY: 'integer_array_value',
    ParameterType.DOUBLE_ARRAY: 'double_array_value',
    ParameterType.STRING_ARRAY: 'string_array_value',
}

_ELEMENT = {
    ParameterType.BOOL_ARRAY: ParameterType.BOOL,
    ParameterType.INTEGER_ARRAY: ParameterType.INTEGER,
    ParameterType.DOUBLE_ARRAY: ParameterType.DOUBLE,
    ParameterType.STRING_ARRAY: ParameterType.STRING,
}
_ARRAY = {element: array for array, element in _ELEMENT.items()}


def _scalar_type(value: object) -> ParameterType | None:
    import numpy as np  # noqa: PLC0415 (lazy: numpy, import time)

    if isinstance(value, (bool, np.bool_)):
        return ParameterType.BOOL
    if isinstance(value, (int, np.integer)):
        return ParameterType.INTEGER
    if isinstance(value, (float, np.floating)):
        return ParameterType.DOUBLE
    if isinstance(value, str):
        return ParameterType.STRING
    return None


def infer_type(value: object, expected: ParameterType = ParameterType.NOT_SET) -> ParameterType:
    """The parameter type of a Python value (``expected`` settles empty lists and int/float)."""
    import numpy as np  # noqa: PLC0415 (lazy: numpy, import time)

    if value is None:
        return ParameterType.NOT_SET
    scalar = _scalar_type(value)
    if scalar is not None:
        if scalar is ParameterType.INTEGER and expected is ParameterType.DOUBLE:
            return ParameterType.DOUBLE
        return scalar
    if isinstance(value, (bytes, bytearray)):
        return ParameterType.BYTE_ARRAY
    if (
        isinstance(value, np.ndarray)
        and value.dtype == np.uint8
        and expected
        in (
            ParameterType.BYTE_ARRAY,
            ParameterType.NOT_SET,
        )
    ):
        return ParameterType.BYTE_ARRAY
    if isinstance(value, (list, tuple, np.ndarray)):
        items = list(value)
        if not items:
            if expected.is_array:
                return expected
            raise ParameterError('an empty list has no parameter type: declare the parameter first')
        kinds = {_scalar_type(item) for item in items}
        if None in kinds:
            raise ParameterError(f'{value!r} holds values no parameter can (bool, int, float, str)')
        if kinds == {ParameterType.INTEGER} and expected is ParameterType.DOUBLE_ARRAY:
            return ParameterType.DOUBLE_ARRAY
        if kinds == {ParameterType.INTEGER, ParameterType.DOUBLE}:
            return ParameterType.DOUBLE_ARRAY
        if len(kinds) != 1:
            names = sorted(kind.ros_name for kind in kinds if kind is not None)
            raise ParameterError(f'a parameter array holds one type, not {" and ".join(names)}')
        return _ARRAY[kinds.pop()]  # type: ignore[index]  # one kind left, not None
    raise ParameterError(f'{type(value).__name__} is not a parameter type')


def normalize(value: object, kind: ParameterType) -> ParamValue:
    """The canonical Python form of a value of type ``kind`` (lists, not arrays or tuples)."""
    if kind is ParameterType.NOT_SET:
        return None
    if kind is ParameterType.BOOL:
        return bool(value)
    if kind is ParameterType.INTEGER:
        return _integer(value)
    if kind is ParameterType.DOUBLE:
        return _double(value)
    if kind is ParameterType.STRING:
        return str(value)
    if not isinstance(value, Iterable):
        raise ParameterError(f'{describe_value(value)} is not a {kind.ros_name}')
    if kind is ParameterType.BYTE_ARRAY:
        return bytes(value)
    if kind is ParameterType.BOOL_ARRAY:
        return [bool(item) for item in value]
    if kind is ParameterType.INTEGER_ARRAY:
        return [_integer(item) for item in value]
    if kind is ParameterType.DOUBLE_ARRAY:
        return [_double(item) for item in value]
    return [str(item) for item in value]


def _integer(value: object) -> int:
    if not isinstance(value, (str, SupportsInt)):
        raise ParameterError(f'{describe_value(value)} is not an integer')
    number = int(value)
    if not -(2**63) <= number < 2**63:
        raise ParameterError(f'{number} does not fit a 64-bit integer parameter')
    return number


def _double(value: object) -> float:
    if not isinstance(value, (str, SupportsFloat)):
        raise ParameterError(f'{describe_value(value)} is not a double')
    return float(value)


def to_message(value: ParamValue, kind: ParameterType, message_class: type[Message]) -> Message:
    """An ``rcl_interfaces/msg/ParameterValue``."""
    message = message_class(type=int(kind))
    if kind is not ParameterType.NOT_SET:
        setattr(message, FIELDS[kind], value)
    return message


def from_message(message: Message) -> tuple[ParamValue, ParameterType]:
    """The Python value and type of an ``rcl_interfaces/msg/ParameterValue``."""
    try:
        kind = ParameterType(message.type)
    except ValueError:
        raise ParameterError(f'unknown parameter type number {message.type}') from None
    if kind is ParameterType.NOT_SET:
        return None, kind
    raw = getattr(message, FIELDS[kind])
    if kind is ParameterType.BYTE_ARRAY:
        return bytes(raw), kind
    if kind.is_array:
        return [item.item() if hasattr(item, 'item') else item for item in raw], kind
    return raw, kind


def is_param_value(value: object) -> TypeGuard[ParamValue]:
    """Whether ``value`` has a parameter value's shape: None, a scalar, bytes or a list of
    scalars (whether a list's items share one type, :func:`infer_type` checks)."""
    if value is None or isinstance(value, (bool, int, float, str, bytes)):
        return True
    return isinstance(value, list) and all(isinstance(x, (bool, int, float, str)) for x in value)


def same(a: object, b: object) -> bool:
    """Whether two parameter values are equal (NaN equals NaN, as a change detector needs)."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return bool(type(a) is type(b) and a == b)


def describe_value(value: object, limit: int = 60) -> str:
    """A short ``repr`` of ``value`` for messages (cut at ``limit``)."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + '...'
