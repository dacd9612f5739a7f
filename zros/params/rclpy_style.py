"""``zros.Parameter``: a parameter built as rclpy's ``rclpy.parameter.Parameter`` is."""

from __future__ import annotations

from typing import TYPE_CHECKING

from zros.params import descriptor
from zros.params.errors import ParameterError
from zros.params.values import ParameterType, from_message, infer_type, normalize

if TYPE_CHECKING:
    from zros.cdr import Message


class Parameter(descriptor.Parameter):
    """rclpy's ``Parameter(name, type_=Parameter.Type.X, value=...)``: ``type_`` defaults to
    the value's; a value that does not agree with ``type_`` raises ValueError, as rclpy's.

    ``node.set_parameters([...])``, ``set_parameters_atomically`` and ``declare_parameters``
    take it; its ``value`` is in zros's canonical form (a list, ``bytes`` for a byte array).
    """

    def __init__(self, name: str, type_: ParameterType | None = None, value: object = None) -> None:
        if isinstance(value, (list, tuple)) and value and all(isinstance(v, bytes) for v in value):
            value = b''.join(value)  # rclpy's byte array: a list of one-byte bytes
        try:
            kind = infer_type(value, ParameterType.NOT_SET if type_ is None else type_)
        except ParameterError as exc:
            raise TypeError(f'parameter {name!r}: {exc}') from None
        if type_ is None:
            type_ = kind
        elif not isinstance(type_, ParameterType):
            raise TypeError(
                f'type_ is a Parameter.Type, not {type_!r} (a value goes as value=, as rclpy has '
                f'it: Parameter({name!r}, value={type_!r}))'
            )
        elif kind is not type_ or _integers_for_doubles(value, type_):
            raise ValueError(f'Type {type_.name} and value {value!r} do not agree')
        object.__setattr__(self, 'name', name)
        object.__setattr__(self, 'value', normalize(value, type_))
        object.__setattr__(self, 'type', type_)

    @classmethod
    def from_parameter_msg(cls, message: Message) -> Parameter:
        """From an ``rcl_interfaces/msg/Parameter``."""
        value, kind = from_message(message.value)
        return cls(message.name, kind, value)

    def __repr__(self) -> str:
        return f'Parameter({self.name!r}, Parameter.Type.{self.type_.name}, {self.value!r})'


def _integers_for_doubles(value: object, type_: ParameterType) -> bool:
    """Whether ints were given for a double (rclpy refuses them, as zros's parameters do)."""
    if type_ is ParameterType.DOUBLE:
        return infer_type(value) is ParameterType.INTEGER
    if type_ is ParameterType.DOUBLE_ARRAY:  # an empty list has no type of its own: fine
        return bool(value) and infer_type(value) is ParameterType.INTEGER_ARRAY
    return False
