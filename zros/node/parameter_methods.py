"""The rclpy-style parameter methods of a node, over its :class:`ParameterStore`."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from zros.params import (
    Descriptor,
    DescriptorFields,
    Parameter,
    ParameterClient,
    ParameterError,
    ParameterStore,
    ParamValue,
    SetResult,
)
from zros.runtime.context import NodeContext

if TYPE_CHECKING:
    from typing_extensions import Unpack


class ParameterMethods:
    """``declare_parameter``, ``get_parameter``, ``set_parameter``... of a node."""

    context: NodeContext
    parameters: ParameterStore  #: the node's own parameters

    def declare_parameter(
        self,
        name: str,
        value: ParamValue = None,
        descriptor: Descriptor | None = None,
        *,
        ignore_override: bool = False,
        **fields: Unpack[DescriptorFields],
    ) -> ParamValue:
        """Declare a parameter and return its value (an override's, if one was given).

        ``fields`` are those of :class:`zros.params.Descriptor`: ``description``, ``read_only``,
        ``integer_range=(low, high, step)``, ``floating_point_range``, ``dynamic_typing``...
        """
        return self.parameters.declare(
            name, value, descriptor, ignore_override=ignore_override, **fields
        )

    def declare_parameters(self, values: Mapping[str, ParamValue]) -> dict[str, ParamValue]:
        """Declare several parameters with their defaults; returns their values."""
        return {name: self.parameters.declare(name, value) for name, value in values.items()}

    def has_parameter(self, name: str) -> bool:
        """Whether the node has declared ``name``."""
        return self.parameters.has(name)

    def get_parameter(self, name: str) -> ParamValue:
        """A parameter's value; ParameterNotDeclaredError for an unknown name."""
        return self.parameters.get(name)

    def get_parameter_or(self, name: str, alternative_value: ParamValue = None) -> ParamValue:
        """A parameter's value, or ``alternative_value`` when it is not declared (rclpy's name;
        rclpy returns a Parameter, zros the value as ``get_parameter`` does)."""
        return self.parameters.get(name) if self.parameters.has(name) else alternative_value

    def set_parameter(self, name: str, value: ParamValue) -> None:
        """Set a parameter; raises ParameterError with the reason when it is refused."""
        result = self.parameters.set(name, value)
        if not result:
            raise ParameterError(result.reason)

    def set_parameters(self, values: Mapping[str, ParamValue]) -> list[SetResult]:
        """Set parameters one by one; a result for each."""
        return self.parameters.set_many(values)

    def undeclare_parameter(self, name: str) -> None:
        """Remove a declared parameter (not a read-only one)."""
        self.parameters.undeclare(name)

    def add_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], object]) -> None:
        """``callback(parameters)`` may refuse changes (return False, ``(False, reason)`` or a
        SetResult); it runs where the node spins when the change comes from the network."""
        self.parameters.add_on_set_callback(callback)

    def parameter_client(self, node_name: str, timeout: float = 5.0) -> ParameterClient:
        """The parameters of another node (``/robot/driver``)."""
        return ParameterClient(node_name, node=self, timeout=timeout)
