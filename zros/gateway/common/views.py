"""The views of the graph both gateways show: the services offered, the nodes serving
parameters (found by their parameter services), the node owning an endpoint."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from zros.keyexpr.kinds import EntityKind
from zros.pubsub.taps import is_hidden

if TYPE_CHECKING:
    from zros.graph import Endpoint, Graph
    from zros.node import Node


def offered_services(
    node: Node, *, exclude_node: str | None = None, include_hidden: bool = False
) -> dict[str, str]:
    """Service names with a server on the graph, and their type (the first, if several)."""
    namespace = node.scheme.namespace
    services: dict[str, set[str]] = {}
    for endpoint in node.graph.endpoints((EntityKind.SERVICE_SERVER,)):
        if exclude_node is not None and endpoint.node == exclude_node:
            continue
        name = endpoint.ros_name(namespace)
        if include_hidden or not is_hidden(name):
            services.setdefault(name, set()).add(endpoint.type_name)
    return {name: sorted(types)[0] for name, types in sorted(services.items())}


PARAMETER_SERVICES = {
    'get_parameters': 'rcl_interfaces/srv/GetParameters',
    'list_parameters': 'rcl_interfaces/srv/ListParameters',
}


def parameter_nodes(services: dict[str, str]) -> list[str]:
    """The nodes serving parameters, found by their ``get_parameters`` and
    ``list_parameters`` services (ROS nodes behind a bridge show no name otherwise)."""
    nodes = []
    suffix = '/get_parameters'
    for name, type_name in services.items():
        if name.endswith(suffix) and type_name == PARAMETER_SERVICES['get_parameters']:
            node = name[: -len(suffix)] or '/'
            if services.get(f'{node}/list_parameters') == PARAMETER_SERVICES['list_parameters']:
                nodes.append(node)
    return sorted(nodes)


def owners(endpoints: Iterable[Endpoint], graph: Graph) -> list[str]:
    """The nodes owning ``endpoints`` (see :func:`endpoint_owner`), sorted, once each."""
    return sorted({endpoint_owner(endpoint, graph) for endpoint in endpoints})


def service_providers(node: Node, names: Iterable[str]) -> dict[str, list[str]]:
    """The nodes serving each of the services ``names`` (those with a server)."""
    wanted = set(names)
    servers: dict[str, list[Endpoint]] = {}
    namespace = node.scheme.namespace
    for endpoint in node.graph.endpoints((EntityKind.SERVICE_SERVER,)):
        name = endpoint.ros_name(namespace)
        if name in wanted:
            servers.setdefault(name, []).append(endpoint)
    return {name: owners(found, node.graph) for name, found in sorted(servers.items())}


def endpoint_owner(endpoint: Endpoint, graph: Graph) -> str:
    """The node an endpoint belongs to: its own (zros, rmw_zenoh), else the bridge's node
    that shows it (ROS nodes behind a bridge are not named), else its Zenoh session."""
    if endpoint.node is not None:
        return endpoint.node
    for bridge in graph.bridges():
        if bridge.zid == endpoint.zid:
            return bridge.node_name
    return f'/zenoh_{endpoint.zid[:8]}'
