"""What a node tells of the ROS graph: names, types, counts, waits (as rclpy's node does)."""

from __future__ import annotations

from zros.deprecation import deprecated
from zros.errors import ZrosError
from zros.graph import Graph, TopicEndpointInfo, graph_of
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.names import expand, join
from zros.runtime.context import NodeContext


class NodeNameNonExistentError(ZrosError, LookupError):
    """The node asked about is not in the graph (rclpy's name)."""


class GraphMethods:
    """``get_topic_names_and_types``, ``count_publishers``, ``wait_for_publishers``..."""

    context: NodeContext

    @property
    def graph(self) -> Graph:
        """The live view of the ROS graph (shared by the nodes of a session)."""
        return graph_of(self.context.transport)

    def _key(self, topic: str) -> str:
        return self.context.wire.key(self.context.resolve_name(topic))

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        """Every topic on the network with its types, as rclpy lists them."""
        return list(self.graph.topics(self.context.wire.namespace).items())

    def get_service_names_and_types(self) -> list[tuple[str, list[str]]]:
        """Every service on the network (servers or clients announced) with its types."""
        return list(self.graph.services(self.context.wire.namespace).items())

    def _names_by_node(
        self, kinds: tuple[EntityKind, ...], node_name: str, node_namespace: str
    ) -> list[tuple[str, list[str]]]:
        node = join(node_namespace, node_name)
        graph = self.graph
        if node not in graph.nodes():
            raise NodeNameNonExistentError(f'node {node} is not in the graph')
        return list(graph.node_names(node, kinds, self.context.wire.namespace).items())

    def get_publisher_names_and_types_by_node(
        self, node_name: str, node_namespace: str
    ) -> list[tuple[str, list[str]]]:
        """The topics a node publishes, with their types (rclpy's; NodeNameNonExistentError
        when the node is not in the graph). A ROS node behind a bridge shows none: the bridge
        does not say which node owns what."""
        return self._names_by_node((EntityKind.PUBLISHER,), node_name, node_namespace)

    def get_subscriber_names_and_types_by_node(
        self, node_name: str, node_namespace: str
    ) -> list[tuple[str, list[str]]]:
        """The topics a node subscribes to, as :meth:`get_publisher_names_and_types_by_node`."""
        return self._names_by_node((EntityKind.SUBSCRIBER,), node_name, node_namespace)

    def get_service_names_and_types_by_node(
        self, node_name: str, node_namespace: str
    ) -> list[tuple[str, list[str]]]:
        """The services a node serves, as :meth:`get_publisher_names_and_types_by_node`."""
        return self._names_by_node((EntityKind.SERVICE_SERVER,), node_name, node_namespace)

    def get_client_names_and_types_by_node(
        self, node_name: str, node_namespace: str
    ) -> list[tuple[str, list[str]]]:
        """The services a node calls, as :meth:`get_publisher_names_and_types_by_node`."""
        return self._names_by_node((EntityKind.SERVICE_CLIENT,), node_name, node_namespace)

    def get_node_names(self) -> list[str]:
        """zros nodes by name, and each bridge's node (ROS nodes hide behind it)."""
        return self.graph.nodes()

    def get_fully_qualified_node_names(self) -> list[str]:
        """``/namespace/name`` of each node in the graph (rclpy's; as :meth:`get_node_names`)."""
        return self.graph.nodes()

    def get_node_names_and_namespaces(self) -> list[tuple[str, str]]:
        """``(name, namespace)`` of each node in the graph (rclpy's)."""
        return [(name, namespace or '/') for namespace, _, name in
                (node.rpartition('/') for node in self.graph.nodes())]  # fmt: skip

    def wait_for_node(self, fully_qualified_node_name: str, timeout: float | None = 5.0) -> bool:
        """Wait until the node (``/namespace/name``; a name without the leading ``/`` is at the
        root) is in the graph; returns whether it was in time (rclpy's)."""
        node = fully_qualified_node_name
        node = node if node.startswith('/') else '/' + node
        graph = self.graph
        return graph.wait_until(lambda: node in graph.nodes(), timeout)

    def _count_service_ends(self, service: str, kind: EntityKind) -> int:
        name = self.context.resolve_name(service, 'service name')
        namespace = self.context.wire.namespace
        return sum(1 for e in self.graph.endpoints((kind,)) if e.ros_name(namespace) == name)

    def count_services(self, service: str) -> int:
        """How many servers of ``service`` are announced (rclpy's)."""
        return self._count_service_ends(service, EntityKind.SERVICE_SERVER)

    def count_clients(self, service: str) -> int:
        """How many clients of ``service`` are announced (rclpy's)."""
        return self._count_service_ends(service, EntityKind.SERVICE_CLIENT)

    def count_publishers(self, topic: str) -> int:
        """How many publishers are announced on ``topic``."""
        return len(self.graph.publishers(self._key(topic)))

    def count_subscribers(self, topic: str) -> int:
        """How many subscribers are announced on ``topic``."""
        return len(self.graph.subscribers(self._key(topic)))

    def get_publishers_info_by_topic(self, topic_name: str) -> list[TopicEndpointInfo]:
        """The publishers on a topic (rclpy's): node, type, GID, QoS of each, as the graph
        knows them (see :class:`zros.graph.TopicEndpointInfo`). ``topic_name`` is expanded with
        the node's namespace but not remapped, as rclpy's."""
        key = self._expanded_key(topic_name)
        return [TopicEndpointInfo.from_endpoint(e) for e in self.graph.publishers(key)]

    def get_subscriptions_info_by_topic(self, topic_name: str) -> list[TopicEndpointInfo]:
        """The subscriptions on a topic (rclpy's), as :meth:`get_publishers_info_by_topic`."""
        key = self._expanded_key(topic_name)
        return [TopicEndpointInfo.from_endpoint(e) for e in self.graph.subscribers(key)]

    def _expanded_key(self, topic: str) -> str:
        context = self.context
        return context.wire.key(expand(topic, context.name, context.namespace))

    def wait_for_publishers(self, topic: str, timeout: float | None = 5.0) -> bool:
        """Wait until a publisher on ``topic`` is announced (by a bridge or another node);
        returns whether one was in time (False after Ctrl-C)."""
        key, graph = self._key(topic), self.graph
        return graph.wait_until(lambda: graph.publishers(key), timeout)

    def wait_for_subscribers(self, topic: str, timeout: float | None = 5.0) -> bool:
        """Wait until a subscriber on ``topic`` is announced (by a bridge or another node);
        returns whether one was in time (False after Ctrl-C). ``Publisher.wait_for_subscribers``
        waits for a subscriber that matches that publisher."""
        key, graph = self._key(topic), self.graph
        return graph.wait_until(lambda: graph.subscribers(key), timeout)

    def wait_for_publisher(self, topic: str, timeout: float | None = 5.0) -> bool:
        """Deprecated: :meth:`wait_for_publishers` (the plural of ``count_publishers``)."""
        deprecated('Node.wait_for_publisher', 'Node.wait_for_publishers')
        return self.wait_for_publishers(topic, timeout)

    def wait_for_subscriber(self, topic: str, timeout: float | None = 5.0) -> bool:
        """Deprecated: :meth:`wait_for_subscribers` (as ``Publisher.wait_for_subscribers``)."""
        deprecated('Node.wait_for_subscriber', 'Node.wait_for_subscribers')
        return self.wait_for_subscribers(topic, timeout)
