"""What the commands ask of the graph: names of a kind listed, filtered and typed, a name that
must be there (or the closest ones named), and the type a topic is published with."""

from __future__ import annotations

import argparse
import difflib
from collections.abc import Iterable
from typing import TYPE_CHECKING

from zros.cli.shared import DISCOVERY, CommandError, open_node, out

if TYPE_CHECKING:
    from zros.node import Node


def names_on_graph(node: Node, kind: str) -> dict[str, list[str]]:
    """The ``'topics'``, ``'services'`` or ``'actions'`` on the network and their types, after
    asking the network for the whole graph."""
    node.graph.refresh(DISCOVERY)
    names: dict[str, list[str]] = getattr(node.graph, kind)(node.scheme.namespace)
    return names


def add_listing_options(parser: argparse.ArgumentParser, kind: str, hidden: bool = True) -> None:
    """ros2's ``-c/--count-<kind>`` and (``hidden``) ``--include-hidden-<kind>`` of a verb
    listing the ``kind`` (topics, services...); :func:`listed` applies them."""
    parser.add_argument(
        '-c',
        f'--count-{kind}',
        dest='count',
        action='store_true',
        help=f'only the number of {kind}',
    )
    if hidden:
        parser.add_argument(
            f'--include-hidden-{kind}', dest='include_hidden', action='store_true',
            help=f'{kind} with a name part starting with _ too (hidden by default, as ros2)',
        )  # fmt: skip


def listed(args: argparse.Namespace, names: dict[str, list[str]]) -> dict[str, list[str]]:
    """``names`` without the hidden ones unless ``--include-hidden-...``."""
    from zros.pubsub.taps import is_hidden

    if getattr(args, 'include_hidden', True):
        return names
    return {name: types for name, types in names.items() if not is_hidden(name)}


def list_names(args: argparse.Namespace, kind: str) -> int:
    """``zros <kind> list [-t] [-c]``."""
    with open_node(args) as node:
        names = listed(args, names_on_graph(node, kind))
        if args.count:
            out(str(len(names)))
            return 0
        for name, types in names.items():
            out(f'{name} [{", ".join(types)}]' if args.show_types else name)
    return 0


def print_types(args: argparse.Namespace, kind: str, name: str) -> int:
    """``zros service|action type NAME``: the types announced for ``name``."""
    with open_node(args) as node:
        resolved = node.resolve_name(name)
        types = names_on_graph(node, kind).get(resolved)
        if not types:
            raise CommandError(f'{kind[:-1]} {resolved} does not appear on the network')
        for type_name in types:
            out(type_name)
    return 0


def find_names(args: argparse.Namespace, kind: str, type_name: str) -> int:
    """``zros <kind> find TYPE [-c]``: the names announced with that type."""
    with open_node(args) as node:
        found = [n for n, types in listed(args, names_on_graph(node, kind)).items()
                 if type_name in types]  # fmt: skip
        for line in [str(len(found))] if args.count else found:
            out(line)
    return 0


def unknown_name(kind: str, name: str, known: Iterable[str], listing: str) -> CommandError:
    """The error for a ``kind`` (topic, service...) the graph does not show: the closest known
    names ("did you mean /chatter?"), else the command ``listing`` them."""
    matches = difflib.get_close_matches(name, list(known), n=3, cutoff=0.6)
    hint = f'did you mean {" or ".join(matches)}?' if matches else f'{listing} shows them'
    return CommandError(f'{kind} {name} does not appear on the network: {hint}')


def require_on_graph(node: Node, kind: str, name: str) -> None:
    """Fail with the closest names unless ``name`` is among the graph's ``'topics'``,
    ``'services'``, ``'actions'`` or ``'nodes'``, once the graph has answered (it normally
    does at once): a mistyped name fails now, not after the whole wait."""
    node.graph.refresh(DISCOVERY)
    if kind == 'nodes':
        known: Iterable[str] = [n for n in node.graph.nodes() if n != node.fully_qualified_name]
    else:
        known = names_on_graph(node, kind)
    if name not in known:
        raise unknown_name(kind[:-1], name, known, f'zros {kind[:-1]} list')


def require_advertised_type(node: Node, kind: str, name: str, type_name: str) -> None:
    """Fail unless the graph's ``'topics'``, ``'services'`` or ``'actions'`` advertise
    ``name`` with ``type_name`` (or not at all): a type that differs fails before anything is
    sent or printed, naming the one the graph shows."""
    node.graph.refresh(DISCOVERY)
    types = names_on_graph(node, kind).get(node.resolve_name(name), [])
    if types and type_name not in types:
        raise CommandError(f'{node.resolve_name(name)} carries {", ".join(types)}, not {type_name}')


def graph_topic_type(node: Node, topic: str, wait: float | None) -> str:
    """The type of a topic from the graph, waiting up to ``wait`` seconds for it to appear;
    ``None``: only until the graph has answered, failing with the closest names."""
    name = node.resolve_name(topic)

    def found() -> list[str]:
        return node.graph.topics(node.scheme.namespace).get(name, [])

    if wait is None:
        require_on_graph(node, 'topics', name)
    else:
        node.graph.wait_until(found, wait)
    types = found()
    if not types:
        raise CommandError(
            f'topic {name} does not appear on the network: give its type, or check the name '
            '(zros topic list)'
        )
    if len(types) > 1:
        raise CommandError(f'topic {name} has several types ({", ".join(types)}): give one')
    return types[0]


def known_type(node: Node, topic: str, type_name: str) -> str:
    """``type_name``, after making sure ``node`` can decode it.

    A type zros cannot resolve is asked of the nodes publishing ``topic``, then of the other
    nodes serving ``~/get_type_description`` (ROS 2 nodes, a zros node playing a bag); the
    answer is registered. When nobody describes it, the UnknownTypeError says where zros looked
    and how to add the definition.
    """
    from zros.cdr.errors import UnknownTypeError
    from zros.services.typeinfo import SERVICE_NAME, learn_type

    try:
        node.registry.get_class(type_name)
        return type_name
    except UnknownTypeError as exc:
        unknown = exc
    key = node.scheme.key(node.resolve_name(topic))
    publishers = [e for e in node.graph.publishers(key) if e.type_name == type_name]
    owners = {e.node: e.type_hash for e in publishers if e.node}
    type_hash = next((e.type_hash for e in publishers if e.type_hash), None)
    suffix = '/' + SERVICE_NAME
    for service in names_on_graph(node, 'services'):
        if service.endswith(suffix):
            owners.setdefault(service[: -len(suffix)], type_hash)
    if learn_type(node, type_name, owners.items(), timeout=DISCOVERY) is not None:
        return type_name
    asked = ', '.join(owners) or 'none serves ~/get_type_description'
    raise CommandError(f'{unknown}\nThe nodes on the network did not describe it ({asked}).')


def subscription_type(node: Node, topic: str, type_name: str | None, wait: float | None) -> str:
    """The type to subscribe to ``topic`` with: ``type_name`` when given (refused when the graph
    advertises another), else the graph's (:func:`graph_topic_type`); made known to ``node``."""
    if not type_name:
        return known_type(node, topic, graph_topic_type(node, topic, wait))
    type_name = known_type(node, topic, type_name)
    require_advertised_type(node, 'topics', topic, node.registry.get_class(type_name).__msgtype__)
    return type_name
