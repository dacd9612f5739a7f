"""The rclpy-style parameter methods of a node, over its :class:`ParameterStore`."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, overload

from zros.params import (
    Descriptor,
    DescriptorFields,
    Parameter,
    ParameterClient,
    ParameterError,
    ParameterNotDeclaredError,
    ParameterStore,
    ParameterType,
    ParamValue,
    SetResult,
)
from zros.params.rclpy_style import Parameter as RclpyParameter
from zros.runtime.context import NodeContext

if TYPE_CHECKING:
    from typing import TypeAlias

    from typing_extensions import Unpack

    from zros.cdr import Message

    #: an entry of rclpy's ``declare_parameters``: (name,), (name, value or type), (name,
    #: value, descriptor)
    DeclareTuple: TypeAlias = (
        tuple[str]
        | tuple[str, ParamValue | ParameterType]
        | tuple[str, ParamValue | ParameterType, Descriptor | Message | None]
    )


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

    @overload
    def declare_parameters(
        self, values: Mapping[str, ParamValue] | Iterable[Parameter]
    ) -> dict[str, ParamValue]: ...

    @overload
    def declare_parameters(
        self,
        values: str,
        parameters: Sequence[DeclareTuple],
        ignore_override: bool = False,
    ) -> list[RclpyParameter]: ...

    def declare_parameters(
        self,
        values: Mapping[str, ParamValue] | Iterable[Parameter] | str,
        parameters: Sequence[DeclareTuple] | None = None,
        ignore_override: bool = False,
    ) -> dict[str, ParamValue] | list[RclpyParameter]:
        """Declare several parameters with their defaults (a mapping, or Parameters); returns
        their values by name.

        rclpy's form, ``declare_parameters(namespace, [(name, value[, descriptor]), ...])``,
        prefixes each name with ``namespace.`` (none when empty) and returns
        :class:`zros.Parameter` objects; a value may be a ``Parameter.Type`` (declared of that
        type, with no value), a descriptor a :class:`Descriptor` or its message.
        """
        if not isinstance(values, str):
            if parameters is not None:
                raise TypeError('declare_parameters(namespace, parameters) takes a namespace first')
            items = values.items() if isinstance(values, Mapping) else values
            pairs = [(item.name, item.value) if isinstance(item, Parameter) else item
                     for item in items]  # fmt: skip
            return {name: self.parameters.declare(name, value) for name, value in pairs}
        if parameters is None:
            raise TypeError('declare_parameters(namespace, parameters) needs the parameters')
        declared = []
        for entry in parameters:
            name = f'{values}.{entry[0]}' if values else entry[0]
            value = entry[1] if len(entry) > 1 else None
            described = entry[2] if len(entry) > 2 else None
            fields: DescriptorFields = {}
            if isinstance(value, ParameterType):
                fields['type'], value = value, None
            if described is not None and not isinstance(described, Descriptor):
                described = Descriptor.from_message(described)
            value = self.parameters.declare(
                name, value, described, ignore_override=ignore_override, **fields
            )
            declared.append(RclpyParameter(name, self.parameters.type_of(name), value))
        return declared

    def set_parameters_atomically(
        self, values: Mapping[str, ParamValue] | Iterable[Parameter]
    ) -> SetResult:
        """Set several parameters, all or none (rclpy's name)."""
        return self.parameters.set_atomically(values)

    def has_parameter(self, name: str) -> bool:
        """Whether the node has declared ``name``."""
        return self.parameters.has(name)

    def get_parameter(self, name: str) -> ParamValue:
        """A parameter's value; ParameterNotDeclaredError for an unknown name."""
        return self.parameters.get(name)

    def get_parameters(self, names: Iterable[str]) -> list[RclpyParameter]:
        """Several parameters as :class:`zros.Parameter` objects (rclpy's ``get_parameters``,
        which returns Parameters where :meth:`get_parameter` returns the value): NOT_SET ones
        for unknown names when undeclared ones are allowed, else ParameterNotDeclaredError."""
        if isinstance(names, str):
            raise TypeError(f'get_parameters takes a list of names, not the str {names!r}')
        names = list(names)
        if not all(isinstance(name, str) for name in names):
            raise TypeError('All names must be instances of type str')
        for name in names:
            self._check_declared(name)
        return [self._rclpy_parameter(name) for name in names]

    def get_parameters_by_prefix(self, prefix: str) -> dict[str, RclpyParameter]:
        """The parameters under ``prefix.`` as :class:`zros.Parameter` objects, by their name
        without ``prefix.`` (rclpy's); every parameter for an empty prefix, ``{}`` when none."""
        start = f'{prefix}.' if prefix else ''
        return {name[len(start) :]: self._rclpy_parameter(name)
                for name in self.parameters.names() if name.startswith(start)}  # fmt: skip

    def _rclpy_parameter(self, name: str) -> RclpyParameter:
        parameter = self.parameters.parameter(name)
        return RclpyParameter(name, parameter.type_, parameter.value)

    def get_parameter_type(self, name: str) -> ParameterType:
        """The type of a parameter's value (rclpy's ``Parameter.Type``); NOT_SET for an
        unknown name when undeclared ones are allowed, else ParameterNotDeclaredError."""
        self._check_declared(name)
        return self.parameters.type_of(name)

    def get_parameter_types(self, names: Iterable[str]) -> list[ParameterType]:
        """The types of several parameters, as :meth:`get_parameter_type`."""
        return [self.get_parameter_type(name) for name in names]

    def describe_parameter(self, name: str) -> Descriptor:
        """A parameter's descriptor (rclpy's, as a :class:`Descriptor`: ranges are tuples);
        an empty one for an unknown name when undeclared ones are allowed, else
        ParameterNotDeclaredError."""
        self._check_declared(name)
        return self.parameters.describe(name)

    def describe_parameters(self, names: Iterable[str]) -> list[Descriptor]:
        """The descriptors of several parameters, as :meth:`describe_parameter`."""
        return [self.describe_parameter(name) for name in names]

    def _check_declared(self, name: str) -> None:
        if not self.parameters.allow_undeclared and not self.parameters.has(name):
            raise ParameterNotDeclaredError(f"parameter '{name}' is not declared")

    def get_parameter_or(self, name: str, alternative_value: ParamValue = None) -> ParamValue:
        """A parameter's value, or ``alternative_value`` when it is not declared (rclpy's name;
        rclpy returns a Parameter, zros the value as ``get_parameter`` does)."""
        return self.parameters.get(name) if self.parameters.has(name) else alternative_value

    def set_parameter(self, name: str, value: ParamValue) -> None:
        """Set a parameter; raises ParameterError with the reason when it is refused."""
        result = self.parameters.set(name, value)
        if not result:
            raise ParameterError(result.reason)

    def set_parameters(
        self, values: Mapping[str, ParamValue] | Iterable[Parameter]
    ) -> list[SetResult]:
        """Set parameters one by one (a mapping, or rclpy's list of :class:`zros.Parameter`);
        a result for each."""
        return self.parameters.set_many(values)

    def undeclare_parameter(self, name: str) -> None:
        """Remove a declared parameter (not a read-only one)."""
        self.parameters.undeclare(name)

    def add_on_set_parameters_callback(
        self, callback: Callable[[list[Parameter]], object]
    ) -> Callable[[list[Parameter]], object]:
        """``callback(parameters)`` may refuse changes (return False, ``(False, reason)`` or a
        SetResult); it runs where the node spins when the change comes from the network.
        Returns ``callback``, for :meth:`remove_on_set_parameters_callback`."""
        return self.parameters.add_on_set_callback(callback)

    def remove_on_set_parameters_callback(
        self, callback: Callable[[list[Parameter]], object]
    ) -> None:
        """Stop calling a callback of :meth:`add_on_set_parameters_callback` (rclpy's);
        ValueError if it is not one."""
        self.parameters.remove_on_set_callback(callback)

    def add_pre_set_parameters_callback(
        self, callback: Callable[[list[Parameter]], list[Parameter]]
    ) -> None:
        """``callback(parameters)`` returns the list of parameters to set instead, before they
        are validated (rclpy's, since Iron): e.g. to set a second parameter along with one.
        Runs on ``set_parameter*`` and network sets, not on declarations; an empty list refuses
        the set, and so does an exception (its reason says which; rclpy would raise it)."""
        self.parameters.add_pre_set_callback(callback)

    def remove_pre_set_parameters_callback(
        self, callback: Callable[[list[Parameter]], list[Parameter]]
    ) -> None:
        """Stop calling a callback of :meth:`add_pre_set_parameters_callback` (rclpy's);
        ValueError if it is not one."""
        self.parameters.remove_pre_set_callback(callback)

    def add_post_set_parameters_callback(self, callback: Callable[[list[Parameter]], None]) -> None:
        """``callback(parameters)`` is told the parameters once they are set or declared
        (rclpy's, since Iron): the place for side effects, after the on-set callbacks accepted
        them. TypeError if ``callback`` is not callable."""
        self.parameters.add_post_set_callback(callback)

    def remove_post_set_parameters_callback(
        self, callback: Callable[[list[Parameter]], None]
    ) -> None:
        """Stop calling a callback of :meth:`add_post_set_parameters_callback` (rclpy's);
        ValueError if it is not one."""
        self.parameters.remove_post_set_callback(callback)

    def parameter_client(self, node_name: str, timeout: float = 5.0) -> ParameterClient:
        """The parameters of another node (``/robot/driver``)."""
        return ParameterClient(node_name, node=self, timeout=timeout)
