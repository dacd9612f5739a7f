"""What a node is made from: its names and remappings, parameter overrides (code, files,
``-p``), sim time, log level, wire, and the session it runs on."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from zros.keyexpr.names import (
    Remapping,
    RosArgs,
    parse_ros_args,
    validate_namespace,
    validate_node_name,
)
from zros.params import ParamValue
from zros.params.files import load_file, parse_override, values_for
from zros.runtime.clock import use_sim_time_from_environment
from zros.runtime.logger import INFO, level_from_environment, parse_level
from zros.transport import Transport, TransportConfig, default_transport
from zros.transport.config import SessionOptions
from zros.wire import chosen_wire, session_defaults

if TYPE_CHECKING:
    from zros.cdr import TypeRegistry

PathLike = str | os.PathLike[str]


class NodeOptions(SessionOptions, total=False):
    """The keyword arguments of ``Node(...)`` that ``zros.init`` passes on."""

    transport: Transport | None
    registry: TypeRegistry | None
    remap: Iterable[str] | dict[str, str] | None
    use_sim_time: bool | None
    log_level: str | int | None
    enable_rosout: bool
    parameters: Mapping[str, ParamValue] | None
    params_file: PathLike | Sequence[PathLike] | None
    allow_undeclared_parameters: bool
    start_parameter_services: bool
    start_type_description_service: bool
    wire: str | None
    domain_id: int | None
    immediate_callbacks: bool
    use_global_arguments: bool


class NodeKeywords(NodeOptions, total=False):
    """Every keyword argument of ``Node(name, namespace, ...)``: what the CLI and the gateways
    hand on to the node they make."""

    connect: str | Sequence[str] | None
    config: TransportConfig | None
    args: Sequence[str] | None
    bridge_namespace: str | None


#: rclpy's keywords of ``Node`` that zros spells otherwise
RCLPY_KEYWORDS = {
    'parameter_overrides': "parameters={'name': value}",
    'automatically_declare_parameters_from_overrides': 'allow_undeclared_parameters=True',
    'cli_args': 'args=[...]',
}


def check_keywords(settings: Mapping[str, object]) -> None:
    """TypeError naming ``Node`` and its keywords for one it does not take (the leftovers would
    otherwise reach ``TransportConfig`` and be reported as its)."""
    unknown = sorted(set(settings) - set(SessionOptions.__annotations__))
    if not unknown:
        return
    hints = [f'for {key} write {RCLPY_KEYWORDS[key]}' for key in unknown if key in RCLPY_KEYWORDS]
    hint = f" (rclpy's: {'; '.join(hints)})" if hints else ''
    which = 'unexpected keyword arguments' if len(unknown) > 1 else 'an unexpected keyword argument'
    raise TypeError(
        f'Node() got {which} {", ".join(map(repr, unknown))}{hint}; '
        f'it takes name, namespace and {", ".join(sorted(NodeKeywords.__annotations__))}'
    )


def parameter_overrides(
    node_fqn: str,
    parameters: Mapping[str, ParamValue] | None,
    params_files: PathLike | Sequence[PathLike] | None,
    ros_args: RosArgs,
) -> dict[str, ParamValue]:
    """A node's parameter values from code, files and ``-p`` (later ones win)."""
    overrides = dict(parameters or {})
    if params_files is None:
        paths: list[PathLike] = []
    elif isinstance(params_files, (str, os.PathLike)):
        paths = [params_files]
    else:
        paths = list(params_files)
    for path in [*paths, *ros_args.params_files]:
        overrides.update(values_for(load_file(path), node_fqn))
    node_name = node_fqn.rpartition('/')[2]
    for name, text in ros_args.parameters.items():
        target, colon, parameter = name.rpartition(':')
        if colon and target not in (node_name, node_fqn, node_fqn.lstrip('/')):
            continue  # -p other_node:name:=value
        overrides[parameter] = parse_override(f'{parameter}:={text}')[1]
    return overrides


_global_args: RosArgs | None = None


def set_global_arguments(argv: Sequence[str] | None) -> None:
    """Make ``argv``'s ``--ros-args`` apply to every node made from now on (rclpy's global
    arguments, which ``zros.init`` sets; None: none). A malformed ``-p`` or ``-r``, an unreadable
    ``--params-file`` or a value that is not YAML raises here, before any node is made."""
    global _global_args  # noqa: PLW0603
    if argv is None:
        _global_args = None
        return
    ros_args = parse_ros_args(argv)
    for path in ros_args.params_files:
        load_file(path)
    for name, text in ros_args.parameters.items():
        parse_override(f'{name}:={text}')
    if ros_args.log_level is not None:
        parse_level(ros_args.log_level)
    _global_args = ros_args


def merge_global(own: RosArgs, use_global_arguments: bool) -> tuple[RosArgs, RosArgs]:
    """(global, own) ``--ros-args`` of a node: its own remappings match first, as in rcl."""
    shared = _global_args if use_global_arguments and _global_args is not None else RosArgs()
    remapping = Remapping(
        own.remapping.rules + shared.remapping.rules,
        own.remapping.node_name or shared.remapping.node_name,
        own.remapping.namespace or shared.remapping.namespace,
    )
    return shared, RosArgs(
        remapping, own.parameters, own.params_files, own.log_level or shared.log_level, own.rest
    )


@dataclass(frozen=True)
class NodeSettings:
    """A node's names, parameter overrides, clock, threshold and wire, from its arguments,
    its ``--ros-args`` and the environment."""

    name: str
    namespace: str
    remapping: Remapping
    overrides: dict[str, ParamValue]
    use_sim_time: bool
    log_level: int
    wire: str

    @property
    def fully_qualified_name(self) -> str:
        """``/namespace/name``."""
        return self.namespace.rstrip('/') + '/' + self.name

    @classmethod
    def parse(
        cls,
        name: str,
        namespace: str,
        *,
        remap: Iterable[str] | dict[str, str] | None,
        args: Sequence[str] | None,
        use_sim_time: bool | None,
        log_level: str | int | None,
        parameters: Mapping[str, ParamValue] | None,
        params_file: PathLike | Sequence[PathLike] | None,
        wire: str | None,
        use_global_arguments: bool = True,
    ) -> NodeSettings:
        """The settings of ``Node(...)``; the command line's win over the arguments', the node's
        own ``args`` over the global ones of ``zros.init``."""
        remapping = Remapping.parse(remap or ())
        shared, ros_args = merge_global(parse_ros_args(args or ()), use_global_arguments)
        remapping = Remapping(
            remapping.rules + ros_args.remapping.rules,
            ros_args.remapping.node_name or remapping.node_name,
            ros_args.remapping.namespace or remapping.namespace,
        )
        name = remapping.node_name or name
        namespace = remapping.namespace or namespace
        validate_node_name(name)
        validate_namespace(namespace)
        fqn = namespace.rstrip('/') + '/' + name
        overrides = parameter_overrides(fqn, parameters, params_file, shared)
        overrides = parameter_overrides(fqn, overrides, None, ros_args)
        if use_sim_time is None:
            if 'use_sim_time' in overrides:
                use_sim_time = overrides['use_sim_time'] is True
            else:
                use_sim_time = use_sim_time_from_environment()
        level = parse_level(
            log_level
            if log_level is not None
            else (ros_args.log_level or level_from_environment() or INFO)
        )
        return cls(name, namespace, remapping, overrides, use_sim_time, level, chosen_wire(wire))


def node_transport(
    transport: Transport | None,
    *,
    connect: str | Sequence[str] | None,
    config: TransportConfig | None,
    wire: str,
    wire_given: bool,
    settings: SessionOptions,
) -> Transport:
    """The session of a node: ``transport``, else the process's (opened with ``config`` or
    the settings of ``TransportConfig.create``, with the session defaults of ``wire``)."""
    if transport is not None:
        if settings or connect is not None or config is not None:
            raise TypeError('a node given a transport= takes no connection settings')
        return transport
    defaults = session_defaults(wire)
    if config is None and (connect is not None or settings or wire_given):
        config = TransportConfig.create(connect=connect, defaults=defaults, **settings)
    elif settings:
        raise TypeError(f'give settings {sorted(settings)} in config=, not beside it')
    return default_transport(config, defaults=defaults)
