"""What a parameter is: its name, value and type, its descriptor (what it may hold, and the
ranges rclcpp checks), and the outcome of setting it."""

from __future__ import annotations

import builtins
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, TypedDict

if TYPE_CHECKING:
    from zros.cdr import Message, TypeRegistry

from zros.params.values import ParameterType, ParamValue, infer_type


class DescriptorFields(TypedDict, total=False):
    """``Descriptor`` fields given by keyword (``declare_parameter(..., read_only=True)``)."""

    type: ParameterType
    description: str
    additional_constraints: str
    read_only: bool
    dynamic_typing: bool
    integer_range: tuple[int, int, int] | None
    floating_point_range: tuple[float, float, float] | None


@dataclass(frozen=True)
class Parameter:
    """A parameter's name, value and type (what set callbacks get; :class:`zros.Parameter` is
    the one rclpy code builds)."""

    name: str
    value: ParamValue
    type: ParameterType | None = None  #: None: inferred from the value

    #: rclpy's ``Parameter.Type``: the same names and numbers
    Type: ClassVar[builtins.type[ParameterType]] = ParameterType

    @property
    def type_(self) -> ParameterType:
        """The type (rclpy's name): :attr:`type`, else the value's."""
        return self.type if self.type is not None else infer_type(self.value)


@dataclass(frozen=True)
class Descriptor:
    """What a parameter may hold (``rcl_interfaces/msg/ParameterDescriptor``).

    Ranges are ``(from, to, step)``; a step of 0 means any value in the range.
    """

    name: str = ''
    type: ParameterType = ParameterType.NOT_SET
    description: str = ''
    additional_constraints: str = ''
    read_only: bool = False
    dynamic_typing: bool = False
    integer_range: tuple[int, int, int] | None = None
    floating_point_range: tuple[float, float, float] | None = None

    def to_message(self, registry: TypeRegistry) -> Message:
        """This descriptor as an ``rcl_interfaces/msg/ParameterDescriptor``."""
        message = registry.get_class('rcl_interfaces/msg/ParameterDescriptor')(
            name=self.name,
            type=int(self.type),
            description=self.description,
            additional_constraints=self.additional_constraints,
            read_only=self.read_only,
            dynamic_typing=self.dynamic_typing,
        )
        if self.integer_range is not None:
            low, high, step = self.integer_range
            range_class = registry.get_class('rcl_interfaces/msg/IntegerRange')
            message.integer_range = [range_class(from_value=low, to_value=high, step=step)]
        if self.floating_point_range is not None:
            low_f, high_f, step_f = self.floating_point_range
            range_class = registry.get_class('rcl_interfaces/msg/FloatingPointRange')
            message.floating_point_range = [
                range_class(from_value=low_f, to_value=high_f, step=step_f)
            ]
        return message

    @classmethod
    def from_message(cls, message: Message) -> Descriptor:
        """A descriptor from an ``rcl_interfaces/msg/ParameterDescriptor``."""
        integer = message.integer_range[0] if len(message.integer_range) else None
        floating = message.floating_point_range[0] if len(message.floating_point_range) else None
        try:
            kind = ParameterType(message.type)
        except ValueError:
            kind = ParameterType.NOT_SET
        return cls(
            name=message.name,
            type=kind,
            description=message.description,
            additional_constraints=message.additional_constraints,
            read_only=message.read_only,
            dynamic_typing=message.dynamic_typing,
            integer_range=(
                (integer.from_value, integer.to_value, integer.step) if integer else None
            ),
            floating_point_range=(
                (floating.from_value, floating.to_value, floating.step) if floating else None
            ),
        )


@dataclass(frozen=True)
class SetResult:
    """The outcome of setting one parameter (or several atomically)."""

    successful: bool
    reason: str = ''

    def __bool__(self) -> bool:
        return self.successful


OK = SetResult(True)


def in_integer_range(value: int, limits: tuple[int, int, int]) -> bool:
    """Whether ``value`` is in an integer range ``(from, to, step)``, as rclcpp checks."""
    low, high, step = limits
    if not low <= value <= high:
        return False
    return step == 0 or value == high or (value - low) % step == 0


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


def in_float_range(value: float, limits: tuple[float, float, float]) -> bool:
    """Whether ``value`` is in a float range ``(from, to, step)``, with rclcpp's tolerance."""
    low, high, step = limits
    if math.isnan(value) or not (low <= value <= high or _close(value, low) or _close(value, high)):
        return False
    if step == 0 or _close(value, high):
        return True
    return _close(value, low + round((value - low) / step) * step)
