"""``zros param``: list, get, set, delete, describe, dump, load (as ``ros2 param``).

Any node serving the six ROS 2 parameter services answers: zros nodes, and ROS nodes behind a
bridge (whose ``ros2 param`` view needs the services, not the node list).
"""

from __future__ import annotations

import argparse
import difflib
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING

from zros.cli.graph_lookup import unknown_name
from zros.cli.shared import (
    DISCOVERY,
    CommandError,
    add_connection_options,
    add_verbs,
    counted,
    open_node,
    out,
)
from zros.errors import ZrosError, command_line_text

if TYPE_CHECKING:
    from zros.node import Node
    from zros.params.client import ParameterClient

_LABELS = {
    'BOOL': 'Boolean value is:',
    'INTEGER': 'Integer value is:',
    'DOUBLE': 'Double value is:',
    'STRING': 'String value is:',
    'BYTE_ARRAY': 'Byte values are:',
    'BOOL_ARRAY': 'Boolean values are:',
    'INTEGER_ARRAY': 'Integer values are:',
    'DOUBLE_ARRAY': 'Double values are:',
    'STRING_ARRAY': 'String values are:',
}


def _client(node: Node, target: str, timeout: float, wait: bool) -> ParameterClient:
    """A client of ``target``'s parameters; unless ``wait``, a node the graph does not show
    fails at once with the closest names, else after ``timeout``."""
    from zros.params.client import ParameterClient

    client = ParameterClient(node.resolve_name(target), node=node, timeout=timeout)
    if not wait and not client.wait_for_node(0):
        node.graph.refresh(DISCOVERY)
        known = set(node.graph.nodes()) | set(_parameter_nodes(node))
        if client.target not in known:
            known.discard(node.fully_qualified_name)
            raise unknown_name('node', client.target, sorted(known), 'zros node list')
    if not client.wait_for_node(timeout):
        node.graph.refresh(DISCOVERY)
        if client.target in node.graph.nodes():  # e.g. the node of another zros command
            raise CommandError(
                f'node {client.target} serves no parameters (it has no parameter services)'
            )
        raise CommandError(f'node {client.target} not found (nothing serves its parameters)')
    return client


def _parameter_nodes(node: Node) -> list[str]:
    """Nodes serving parameters: those with a ``<node>/get_parameters`` service."""
    suffix = '/get_parameters'
    services = node.graph.services(node.scheme.namespace)
    return sorted(name[: -len(suffix)] for name in services if name.endswith(suffix))


def list_parameters(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        if args.node:
            targets = [node.resolve_name(args.node)]
        else:
            node.graph.refresh(DISCOVERY)
            targets = _parameter_nodes(node)
        for target in targets:
            try:
                client = _client(node, target, args.timeout, args.wait)
                names = sorted(client.list_parameters(args.prefixes or ()))
                kinds = client.get_parameter_types(names) if args.param_type and names else {}
            except (ZrosError, CommandError) as exc:
                if args.node:
                    raise
                # as ros2's: one node that does not answer does not hide the others (exit 0)
                print(f'zros: error: {command_line_text(exc)}', file=sys.stderr)
                continue
            if not args.node:
                out(f'{target}:')
            for name in names:
                suffix = f' (type: {kinds[name].ros_name})' if args.param_type else ''
                out(f'  {name}{suffix}')
    return 0


def _closest_parameters(client: ParameterClient, name: str) -> str:
    """``': did you mean rate?'`` when ``name`` is not one of the node's parameters but close
    to some (difflib), else ``''``."""
    names = client.list_parameters(())
    matches = [] if name in names else difflib.get_close_matches(name, names, n=3, cutoff=0.6)
    return f': did you mean {" or ".join(matches)}?' if matches else ''


def get(args: argparse.Namespace) -> int:
    from zros.params.values import ParameterType

    with open_node(args) as node:
        client = _client(node, args.node, args.timeout, args.wait)
        kind = client.get_parameter_types([args.name])[args.name]
        if kind is ParameterType.NOT_SET:
            hint = _closest_parameters(client, args.name)
            raise CommandError(f'parameter {args.name} not set on {client.target}{hint}')
        value = client.get(args.name)
        if isinstance(value, (bytes, bytearray)):
            value = list(value)
        out(str(value) if args.hide_type else f'{_LABELS[kind.name]} {value}')
    return 0


def set_parameter(args: argparse.Namespace) -> int:
    from zros.params.descriptor import Parameter
    from zros.params.files import set_value
    from zros.params.values import ParameterType

    value = set_value(args.value)
    with open_node(args) as node:
        client = _client(node, args.node, args.timeout, args.wait)
        kind = None
        if value == []:  # an empty array of the parameter's type (ros2 sends a bool array)
            declared = client.get_parameter_types([args.name])[args.name]
            kind = declared if declared.is_array else ParameterType.BOOL_ARRAY
        (result,) = client.set_parameters([Parameter(args.name, value, kind)])
        if not result:
            hint = _closest_parameters(client, args.name)
            out(f'Setting parameter failed: {result.reason}{hint}')
            return 1
    out('Set parameter successful')
    return 0


def delete(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        (result,) = _client(node, args.node, args.timeout, args.wait).set_parameters(
            {args.name: None}
        )
    if not result:
        out(f'Deleting parameter failed: {result.reason}')
        return 1
    out('Deleted parameter successfully')
    return 0


def describe(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        client = _client(node, args.node, args.timeout, args.wait)
        names = args.names
        descriptors = client.describe_parameters(names)
        kinds = client.get_parameter_types(names)
    for name in names:
        descriptor = descriptors[name]
        out(f'Parameter name: {name}')
        out(f'  Type: {kinds[name].ros_name}')
        if descriptor.description:
            out(f'  Description: {descriptor.description}')
        out('  Constraints:')
        if descriptor.read_only:
            out('    Read only: true')
        if descriptor.dynamic_typing:
            out('    Dynamic typing: true')
        if descriptor.additional_constraints:
            out(f'    Additional constraints: {descriptor.additional_constraints}')
        for value_range in (descriptor.integer_range, descriptor.floating_point_range):
            if value_range is not None:
                low, high, step = value_range
                out(f'    Min value: {low}')
                out(f'    Max value: {high}')
                if step:
                    out(f'    Step: {step}')
    return 0


def dump(args: argparse.Namespace) -> int:
    from zros.params.files import dump as dump_file

    with open_node(args) as node:
        client = _client(node, args.node, args.timeout, args.wait)
        names = client.list_parameters()
        values = client.get_parameters(names) if names else {}
    text = dump_file(client.target, values)
    if args.output:
        with open(args.output, 'w', encoding='utf-8') as file:
            file.write(text)
        out(f'Saved parameters of {client.target} to {args.output}')
    else:
        out(text.rstrip('\n'))
    return 0


def load(args: argparse.Namespace) -> int:
    from zros.params.errors import ParameterError
    from zros.params.files import load_file, values_for

    try:
        entries = load_file(args.file)
    except (OSError, ParameterError) as exc:
        raise CommandError(command_line_text(exc)) from None
    failed = 0
    with open_node(args) as node:
        client = _client(node, args.node, args.timeout, args.wait)
        values = values_for(entries, client.target)
        if not values:
            raise CommandError(f'{args.file} has no parameters for {client.target}')
        if args.atomic:
            result = client.set_parameters_atomically(values)
            if not result:
                out(f'Setting parameters failed: {result.reason}')
                return 1
            out(f'Set {counted(len(values), "parameter")} successfully')
            return 0
        for (name, _), result in zip(values.items(), client.set_parameters(values), strict=True):
            if result:
                out(f'Set parameter {name} successful')
            else:
                failed += 1
                out(f'Set parameter {name} failed: {result.reason}')
    return 1 if failed else 0


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'param', help_line)

    def verb(
        name: str,
        help_text: str,
        target: Callable[[argparse.Namespace], int],
        node_optional: bool = False,
    ) -> argparse.ArgumentParser:
        sub = verbs.add_parser(name, help=help_text, description=help_text)
        sub.set_defaults(run=target)
        if node_optional:
            sub.add_argument('node', nargs='?', help='e.g. /robot/driver (default: all)')
        else:
            sub.add_argument('node', help='e.g. /robot/driver')
        sub.add_argument('--timeout', type=float, default=5.0, help='seconds for each answer')
        sub.add_argument('--wait', action='store_true',
                         help='wait up to --timeout for the node to appear (without: a node '
                         'not on the network fails at once, with the closest names)')  # fmt: skip
        add_connection_options(sub)
        return sub

    sub = verb(
        'list',
        'the parameters of a node, or of every node (one that does not answer: an error on '
        'stderr, the others still listed)',
        list_parameters,
        True,
    )
    sub.add_argument('--param-prefixes', dest='prefixes', nargs='*', default=[])
    sub.add_argument('--param-type', action='store_true', help='with their types')
    sub = verb('get', "a parameter's value", get)
    sub.add_argument('name')
    sub.add_argument('--hide-type', action='store_true', help='only the value')
    sub = verb(
        'set', 'set a parameter (the value is YAML: 1, 1.0, true, "[1, 2]"...)', set_parameter
    )
    sub.add_argument('name')
    sub.add_argument('value')
    sub = verb('delete', 'undeclare a parameter', delete)
    sub.add_argument('name')
    sub = verb('describe', "parameters' types and constraints", describe)
    sub.add_argument('names', nargs='+', metavar='name')
    sub = verb('dump', "a node's parameters as a parameter file", dump)
    sub.add_argument('-o', '--output', metavar='FILE', help='write to FILE, not the screen')
    sub = verb('load', 'set parameters from a parameter file', load)
    sub.add_argument('file')
    sub.add_argument('--atomic', action='store_true', help='all or none')
