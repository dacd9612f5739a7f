"""``zros node``: list and info (as ``ros2 node``), from what the graph view knows.

zros nodes announce themselves by name. ROS nodes behind a zenoh-bridge-ros2dds do not: the
bridge shows its ROS entities as its own, so they appear under the bridge's node name.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from zros.cli.graph_lookup import unknown_name
from zros.cli.shared import DISCOVERY, add_connection_options, add_verbs, open_node, out

if TYPE_CHECKING:
    from zros.graph import Endpoint
    from zros.node import Node

_SECTIONS = (
    ('Subscribers', 'MS'),
    ('Publishers', 'MP'),
    ('Service Servers', 'SS'),
    ('Service Clients', 'SC'),
    ('Action Servers', 'AS'),
    ('Action Clients', 'AC'),
)


#: what ``node list`` says (once, on stderr) when nodes share a name, as ``ros2 node list`` does
SHARED_NAMES = (
    'zros: warning: some nodes on the network share a full name (each is listed); '
    'whatever reaches a node by name (parameters, node info) may reach either'
)


def _others(node: Node) -> list[str]:
    """The nodes on the graph but the command's own, once per node (a shared name repeats)."""
    own = node.fully_qualified_name
    return [name for name in node.graph.node_instances() if name != own]


def list_nodes(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        node.graph.refresh(DISCOVERY)
        names = [n for n in _others(node) if args.all or not n.rsplit('/', 1)[-1].startswith('_')]
        if len(set(names)) < len(names):
            print(SHARED_NAMES, file=sys.stderr)
        if args.count_nodes:
            out(str(len(names)))
            return 0
        for name in names:
            out(name)
    return 0


def _endpoints_of(node: Node, name: str) -> list[Endpoint]:
    for bridge in node.graph.bridges():
        if bridge.node_name == name:
            return [e for e in node.graph.endpoints() if e.is_bridged and e.zid == bridge.zid]
    return node.graph.node_endpoints(name)


def info(args: argparse.Namespace) -> int:
    with open_node(args) as node:
        node.graph.refresh(DISCOVERY)
        name = node.resolve_name(args.node)
        others = _others(node)
        if name not in others:
            raise unknown_name('node', name, set(others), 'zros node list')
        sharing = others.count(name)
        if sharing > 1:
            print(
                f'zros: warning: {sharing} nodes on the network are named {name}; '
                'what follows is what they announce together',
                file=sys.stderr,
            )
        endpoints = _endpoints_of(node, name)
        out(name)
        for title, code in _SECTIONS:
            out(f'  {title}:')
            lines = {
                f'    {e.ros_name(node.scheme.namespace)}: {e.type_name}'
                for e in endpoints
                if e.kind.value == code
            }
            for line in sorted(lines):
                out(line)
    return 0


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'node', help_line)
    listing = verbs.add_parser('list', help='list the nodes on the network')
    listing.add_argument('-c', '--count-nodes', action='store_true', help='only their number')
    listing.add_argument(
        '-a', '--all', action='store_true', help='hidden nodes (a name starting with _) too'
    )
    listing.set_defaults(run=list_nodes)
    add_connection_options(listing)
    detail = verbs.add_parser('info', help="a node's publishers, subscribers, services, actions")
    detail.add_argument('node', help='e.g. /robot/driver')
    detail.set_defaults(run=info)
    add_connection_options(detail)
