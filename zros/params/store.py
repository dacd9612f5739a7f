"""A node's parameters: declared with descriptors, validated on every change, vetoable.

The reasons given for refusals are those rclcpp gives, since ROS 2 tools print them.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from typing_extensions import Unpack

from zros.params.descriptor import (
    OK,
    Descriptor,
    DescriptorFields,
    Parameter,
    SetResult,
    in_float_range,
    in_integer_range,
)
from zros.params.errors import ParameterError, ParameterNotDeclaredError
from zros.params.files import dump as dump_file
from zros.params.values import ParameterType, ParamValue, infer_type, normalize, same


def _items(values: Mapping[str, ParamValue] | Iterable[Parameter]) -> list[Parameter]:
    if isinstance(values, Mapping):
        return [Parameter(name, value) for name, value in values.items()]
    return list(values)


SetCallback = Callable[[list[Parameter]], object]
#: rclpy's pre-set callback: the parameters to set in, the parameters to set instead out
PreSetCallback = Callable[[list[Parameter]], list[Parameter]]
#: rclpy's post-set callback: told the parameters that were set
PostSetCallback = Callable[[list[Parameter]], None]
ChangeCallback = Callable[[list[Parameter], list[Parameter], list[Parameter]], None]


def _callback_result(answer: object) -> SetResult:
    if answer is None or answer is True:
        return OK
    if answer is False:
        return SetResult(False, 'refused by a callback')
    if isinstance(answer, SetResult):
        return answer
    if hasattr(answer, 'successful') and hasattr(answer, 'reason'):  # an rclpy-style message
        return SetResult(bool(answer.successful), str(answer.reason))
    if isinstance(answer, tuple) and len(answer) == 2:
        return SetResult(bool(answer[0]), str(answer[1]))
    raise TypeError(f'a set callback returns SetResult, a bool or (bool, reason), not {answer!r}')


@dataclass
class _Entry:
    value: ParamValue
    descriptor: Descriptor
    kind: ParameterType = field(default=ParameterType.NOT_SET)


class ParameterStore:
    """The parameters of one node.

    ``overrides`` (from parameter files and ``-p name:=value``) replace the default of a
    parameter when it is declared; with ``allow_undeclared`` they are declared at once, and
    setting an unknown name declares it.
    """

    def __init__(
        self,
        node_name: str,
        overrides: Mapping[str, ParamValue] | None = None,
        allow_undeclared: bool = False,
    ) -> None:
        self.node_name = node_name
        self.overrides: dict[str, ParamValue] = dict(overrides or {})
        self.allow_undeclared = allow_undeclared
        self._entries: dict[str, _Entry] = {}
        self._callbacks: list[SetCallback] = []
        self._checks: list[SetCallback] = []
        self._pre_callbacks: list[PreSetCallback] = []
        self._post_callbacks: list[PostSetCallback] = []
        self._watchers: list[
            Callable[[list[Parameter], list[Parameter], list[Parameter]], None]
        ] = []
        self._lock = threading.RLock()
        #: called after every change with (new, changed, deleted) parameters
        self.on_change: (
            Callable[[list[Parameter], list[Parameter], list[Parameter]], None] | None
        ) = None
        if allow_undeclared:
            for name, value in self.overrides.items():
                self.declare(name, value, Descriptor(dynamic_typing=True))

    # --- declaring ---------------------------------------------------------------------------

    def declare(
        self,
        name: str,
        value: ParamValue = None,
        descriptor: Descriptor | None = None,
        *,
        ignore_override: bool = False,
        **fields: Unpack[DescriptorFields],
    ) -> ParamValue:
        """Declare a parameter; returns its value (the override's, if one was given)."""
        if not name:
            raise ParameterError('a parameter needs a name')
        descriptor = replace(descriptor or Descriptor(), name=name, **fields)
        if not ignore_override and name in self.overrides:
            value = self.overrides[name]
        with self._lock:
            if name in self._entries:
                raise ParameterError(f"parameter '{name}' has already been declared")
            kind = self._type_of(name, value, descriptor)
            value = normalize(value, kind)
            if descriptor.type is ParameterType.NOT_SET and not descriptor.dynamic_typing:
                descriptor = replace(descriptor, type=kind)
            parameter = Parameter(name, value, kind)
            problem = self._check_value(parameter, descriptor) or self._run_callbacks([parameter])
            if problem:
                raise ParameterError(problem)
            self._entries[name] = _Entry(value, descriptor, kind)
        self._changed([parameter], [], [])
        self._run_post_callbacks([parameter])
        return value

    def _type_of(self, name: str, value: ParamValue, descriptor: Descriptor) -> ParameterType:
        try:
            kind = infer_type(value, descriptor.type)
        except ParameterError as exc:
            raise ParameterError(f"parameter '{name}': {exc}") from None
        return kind

    def undeclare(self, name: str) -> None:
        """Remove a parameter (not a read-only one)."""
        with self._lock:
            entry = self._entries.get(name)
            if entry is None:
                raise ParameterNotDeclaredError(f"parameter '{name}' is not declared")
            if entry.descriptor.read_only:
                raise ParameterError(f"cannot undeclare parameter '{name}': it is read-only")
            del self._entries[name]
        self._changed([], [], [Parameter(name, None)])

    # --- reading -----------------------------------------------------------------------------

    def has(self, name: str) -> bool:
        """Whether ``name`` is declared."""
        with self._lock:
            return name in self._entries

    def get(self, name: str) -> ParamValue:
        """The value of a parameter (None for an unknown one when undeclared ones are allowed)."""
        with self._lock:
            entry = self._entries.get(name)
        if entry is None:
            if self.allow_undeclared:
                return None
            raise ParameterNotDeclaredError(f"parameter '{name}' is not declared")
        return entry.value

    def parameter(self, name: str) -> Parameter:
        """``name`` as a :class:`Parameter` (type ``NOT_SET`` when absent)."""
        with self._lock:
            entry = self._entries.get(name)
        if entry is None:
            return Parameter(name, None, ParameterType.NOT_SET)
        return Parameter(name, entry.value, entry.kind)

    def type_of(self, name: str) -> ParameterType:
        """The type of a parameter's value (NOT_SET for unknown names)."""
        with self._lock:
            entry = self._entries.get(name)
        return entry.kind if entry is not None else ParameterType.NOT_SET

    def describe(self, name: str) -> Descriptor:
        """The descriptor of a parameter (an empty one, type NOT_SET, for unknown names)."""
        with self._lock:
            entry = self._entries.get(name)
        if entry is None:
            return Descriptor(name=name)
        return replace(entry.descriptor, type=entry.kind)

    def names(self) -> list[str]:
        """The declared names, sorted."""
        with self._lock:
            return sorted(self._entries)

    def values(self) -> dict[str, ParamValue]:
        """Every parameter's value, by name."""
        with self._lock:
            return {name: entry.value for name, entry in sorted(self._entries.items())}

    def list_parameters(
        self, prefixes: Iterable[str] = (), depth: int = 0
    ) -> tuple[list[str], list[str]]:
        """Names and their prefixes as ``list_parameters`` gives them.

        With no prefixes: every name with fewer than ``depth`` dots (all with depth 0). With
        prefixes: names equal to one, or under one at most ``depth`` levels down (rclpy's rule;
        rclcpp counts one level fewer).
        """
        prefixes = list(prefixes)
        names: list[str] = []
        found: list[str] = []
        for name in self.names():
            if prefixes:
                listed = any(
                    name == prefix
                    or (
                        name.startswith(prefix + '.')
                        and (depth == 0 or name[len(prefix) + 1 :].count('.') < depth)
                    )
                    for prefix in prefixes
                )
            else:
                listed = depth == 0 or name.count('.') < depth
            if listed:
                names.append(name)
                prefix, dot, _ = name.rpartition('.')
                if dot and prefix not in found:
                    found.append(prefix)
        return names, found

    def dump(self) -> str:
        """The parameters as a ROS 2 parameter file."""
        return dump_file(self.node_name, self.values())

    # --- setting -----------------------------------------------------------------------------

    def add_on_set_callback(self, callback: SetCallback, internal: bool = False) -> SetCallback:
        """``callback(parameters)`` may refuse a change: it returns a SetResult, a bool, or
        ``(ok, reason)`` (None means accept). It runs before every change, declarations too.
        ``internal`` ones are zros's own checks, which may run on any thread."""
        with self._lock:
            (self._checks if internal else self._callbacks).append(callback)
        return callback

    def remove_on_set_callback(self, callback: SetCallback) -> None:
        """Remove a callback added by :meth:`add_on_set_callback`."""
        with self._lock:
            self._callbacks.remove(callback)

    def add_pre_set_callback(self, callback: PreSetCallback) -> PreSetCallback:
        """``callback(parameters)`` returns the parameters to set instead (rclpy's pre-set
        callback); it runs before validation on every set, not on declarations. The last added
        runs first, as rclpy's; with several, the lists they return are joined."""
        if not callable(callback):
            raise TypeError(f'a pre-set callback must be callable, not {callback!r}')
        with self._lock:
            self._pre_callbacks.insert(0, callback)
        return callback

    def remove_pre_set_callback(self, callback: PreSetCallback) -> None:
        """Remove a callback added by :meth:`add_pre_set_callback` (ValueError if it is not
        one)."""
        with self._lock:
            self._pre_callbacks.remove(callback)

    def add_post_set_callback(self, callback: PostSetCallback) -> PostSetCallback:
        """``callback(parameters)`` is told the parameters after they were set or declared
        (rclpy's post-set callback); the last added runs first, as rclpy's."""
        if not callable(callback):
            raise TypeError(f'a post-set callback must be callable, not {callback!r}')
        with self._lock:
            self._post_callbacks.insert(0, callback)
        return callback

    def remove_post_set_callback(self, callback: PostSetCallback) -> None:
        """Remove a callback added by :meth:`add_post_set_callback` (ValueError if it is not
        one)."""
        with self._lock:
            self._post_callbacks.remove(callback)

    @property
    def has_callbacks(self) -> bool:
        """Whether user callbacks watch changes (then network sets wait for a spin)."""
        return bool(self._callbacks or self._pre_callbacks or self._post_callbacks)

    def _run_pre_callbacks(self, parameters: list[Parameter]) -> list[Parameter] | str:
        """The parameters the pre-set callbacks return instead (``parameters`` when there
        are none), or why the set is refused."""
        if not self._pre_callbacks:
            return parameters
        modified: list[Parameter] = []
        for callback in list(self._pre_callbacks):
            try:
                answer = callback(list(parameters))
            except Exception as exc:  # a user callback: its error is the refusal's reason
                return f'a pre-set callback raised {exc!r}'
            if not isinstance(answer, (list, tuple)) or not all(
                isinstance(item, Parameter) for item in answer
            ):
                return f'a pre-set callback returns a list of Parameters, not {answer!r}'
            modified.extend(answer)
        if not modified:
            return (
                'parameter list cannot be empty, this might be due to '
                'pre_set_parameters_callback modifying the original parameters list.'
            )
        return modified

    def _run_post_callbacks(self, parameters: list[Parameter]) -> None:
        for callback in list(self._post_callbacks):
            callback(parameters)

    def _run_callbacks(self, parameters: list[Parameter]) -> str | None:
        for callback in [*self._checks, *self._callbacks]:
            try:
                result = _callback_result(callback(parameters))
            except Exception as exc:  # a user callback: its error is the refusal's reason
                return f'a set callback raised {exc!r}'
            if not result:
                return result.reason or 'refused by a callback'
        return None

    def _check_value(self, parameter: Parameter, descriptor: Descriptor) -> str | None:
        name, value, kind = parameter.name, parameter.value, parameter.type
        if descriptor.integer_range is not None and kind in (
            ParameterType.INTEGER,
            ParameterType.INTEGER_ARRAY,
        ):
            items = value if isinstance(value, list) else [value]
            if not all(
                isinstance(item, int) and in_integer_range(item, descriptor.integer_range)
                for item in items
            ):
                return f"Parameter {{{name}}} doesn't comply with integer range."
        if descriptor.floating_point_range is not None and kind in (
            ParameterType.DOUBLE,
            ParameterType.DOUBLE_ARRAY,
        ):
            items = value if isinstance(value, list) else [value]
            if not all(
                isinstance(item, (int, float))
                and in_float_range(item, descriptor.floating_point_range)
                for item in items
            ):
                return f"Parameter {{{name}}} doesn't comply with floating point range."
        return None

    def _prepare(
        self, name: str, value: ParamValue, kind_hint: ParameterType | None
    ) -> tuple[Parameter, str | None, str]:
        """The parameter a set would make, a refusal reason, and what it does (new/changed/
        deleted)."""
        entry = self._entries.get(name)
        if entry is None and not self.allow_undeclared:
            return (
                Parameter(name, value),
                (f"parameter '{name}' cannot be set because it was not declared"),
                '',
            )
        descriptor = (
            entry.descriptor if entry is not None else Descriptor(name, dynamic_typing=True)
        )
        if entry is not None and descriptor.read_only:
            return (
                Parameter(name, value),
                (f"parameter '{name}' cannot be set because it is read-only"),
                '',
            )
        expected = descriptor.type if not descriptor.dynamic_typing else ParameterType.NOT_SET
        try:
            kind = kind_hint if kind_hint is not None else infer_type(value, expected)
            if kind_hint is None and _integers(value):  # ROS's rule: no int for a double
                kind = ParameterType.INTEGER if kind is ParameterType.DOUBLE else kind
                kind = ParameterType.INTEGER_ARRAY if kind is ParameterType.DOUBLE_ARRAY else kind
            value = normalize(value, kind)
        except (ParameterError, TypeError, ValueError) as exc:
            return Parameter(name, value), f"parameter '{name}': {exc}", ''
        parameter = Parameter(name, value, kind)
        if kind is ParameterType.NOT_SET:
            if entry is None:
                return parameter, None, ''
            if not descriptor.dynamic_typing and descriptor.type is not ParameterType.NOT_SET:
                return (
                    parameter,
                    (
                        f'Static parameter cannot be undeclared, parameter {{{name}}} is of type '
                        f'{{{descriptor.type.ros_name}}}'
                    ),
                    '',
                )
            return parameter, None, 'deleted'
        if expected is not ParameterType.NOT_SET and kind is not expected:
            return (
                parameter,
                (
                    f'Wrong parameter type, parameter {{{name}}} is of type '
                    f'{{{expected.ros_name}}}, setting it to {{{kind.ros_name}}} is not allowed.'
                    + _write_double(name, value, expected, kind)
                ),
                '',
            )
        problem = self._check_value(parameter, descriptor)
        return parameter, problem, 'changed' if entry is not None else 'new'

    def set_atomically(self, values: Mapping[str, ParamValue] | Iterable[Parameter]) -> SetResult:
        """Set several parameters, all or none; the pre-set callbacks may change which."""
        items = self._run_pre_callbacks(_items(values))
        if isinstance(items, str):
            return SetResult(False, items)
        new: list[Parameter] = []
        changed: list[Parameter] = []
        deleted: list[Parameter] = []
        with self._lock:
            prepared = []
            for item in items:
                hint = ParameterType.NOT_SET if item.value is None else item.type
                parameter, problem, action = self._prepare(item.name, item.value, hint)
                if problem:
                    return SetResult(False, problem)
                prepared.append((parameter, action))
            problem = self._run_callbacks([parameter for parameter, _ in prepared])
            if problem:
                return SetResult(False, problem)
            for parameter, action in prepared:
                kind = parameter.type or ParameterType.NOT_SET
                if action == 'deleted':
                    self._entries.pop(parameter.name, None)
                    deleted.append(parameter)
                elif action == 'new':
                    self._entries[parameter.name] = _Entry(
                        parameter.value, Descriptor(parameter.name, dynamic_typing=True), kind,
                    )  # fmt: skip
                    new.append(parameter)
                elif action == 'changed':
                    entry = self._entries[parameter.name]
                    if not (entry.kind is kind and same(entry.value, parameter.value)):
                        changed.append(parameter)
                    entry.value, entry.kind = parameter.value, kind
        self._changed(new, changed, deleted)
        self._run_post_callbacks([parameter for parameter, _ in prepared])
        return OK

    def set(self, name: str, value: ParamValue) -> SetResult:
        """Set one parameter (None undeclares a dynamically typed one)."""
        return self.set_atomically([Parameter(name, value)])

    def set_many(self, values: Mapping[str, ParamValue] | Iterable[Parameter]) -> list[SetResult]:
        """Set parameters one by one: each succeeds or fails on its own."""
        return [self.set_atomically([item]) for item in _items(values)]

    def _changed(
        self, new: list[Parameter], changed: list[Parameter], deleted: list[Parameter]
    ) -> None:
        if not (new or changed or deleted):
            return
        for watcher in tuple(self._watchers):
            watcher(new, changed, deleted)
        if self.on_change is not None:
            self.on_change(new, changed, deleted)

    def add_on_change(
        self, watcher: Callable[[list[Parameter], list[Parameter], list[Parameter]], None]
    ) -> None:
        """Call ``watcher(new, changed, deleted)`` after every change (the node's own reactions,
        such as ``use_sim_time``; :attr:`on_change` stays the parameter server's)."""
        self._watchers.append(watcher)

    def __repr__(self) -> str:
        return f'<zros parameters of {self.node_name}: {len(self._entries)}>'


def _integers(value: object) -> bool:
    """Whether ``value`` is an int or a non-empty list of ints (not bools)."""
    items = value if isinstance(value, list) and value else [value]
    return all(isinstance(item, int) and not isinstance(item, bool) for item in items)


def _write_double(
    name: str, value: ParamValue, expected: ParameterType, kind: ParameterType
) -> str:
    """`` speed is a double: write 2.0`` when an integer was given for a double."""
    if (expected, kind) == (ParameterType.DOUBLE, ParameterType.INTEGER):
        return f' {name} is a double: write {float(value)!r}'  # type: ignore[arg-type]
    if (expected, kind) == (ParameterType.DOUBLE_ARRAY, ParameterType.INTEGER_ARRAY):
        return f' {name} is a double_array: write {[float(v) for v in value]!r}'  # type: ignore[union-attr]
    return ''
