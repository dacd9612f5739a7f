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


class NodeKeywords(NodeOptions, total=False):
    """Every keyword argument of ``Node(name, namespace, ...)``: what the CLI and the gateways
    hand on to the node they make."""

    connect: str | Sequence[str] | None
    config: TransportConfig | None
    args: Sequence[str] | None
    bridge_namespace: str | None


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
    ) -> NodeSettings:
        """The settings of ``Node(...)``; the command line's win over the arguments'."""
        remapping = Remapping.parse(remap or ())
        ros_args = parse_ros_args(args or ())
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
        overrides = parameter_overrides(fqn, parameters, params_file, ros_args)
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
