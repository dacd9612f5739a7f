"""rclpy's ``TopicEndpointInfo``: a publisher or subscription of a topic, as the graph knows it."""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from zros.keyexpr.kinds import EntityKind
from zros.qos import QoS
from zros.wire import Endpoint

#: what rmw gives for an endpoint whose node is not known (a ROS node behind a bridge)
NODE_NAME_UNKNOWN = '_NODE_NAME_UNKNOWN_'
NODE_NAMESPACE_UNKNOWN = '_NODE_NAMESPACE_UNKNOWN_'


class TopicEndpointType(enum.IntEnum):
    """rclpy's ``TopicEndpointTypeEnum`` (the same values)."""

    INVALID = 0
    PUBLISHER = 1
    SUBSCRIPTION = 2


@dataclass(frozen=True)
class TopicEndpointInfo:
    """One endpoint of a topic with rclpy's ``TopicEndpointInfo`` attribute names.

    ``endpoint_gid`` is the GID's bytes as ints where the wire gives one (rmw_zenoh), else
    empty (a bridge announces none); ``qos_profile`` is None where the wire tells no QoS;
    ``topic_type_hash`` is the ``RIHS01_...`` string, empty when not announced. A bridged ROS
    node is ``_NODE_NAME_UNKNOWN_`` in ``_NODE_NAMESPACE_UNKNOWN_``, as rmw reports one it
    cannot name.
    """

    node_name: str
    node_namespace: str
    topic_type: str
    endpoint_type: TopicEndpointType
    endpoint_gid: list[int] = field(default_factory=list)
    qos_profile: QoS | None = None
    topic_type_hash: str = ''

    @classmethod
    def from_endpoint(cls, endpoint: Endpoint) -> TopicEndpointInfo:
        """The info of a publisher or subscriber the graph holds."""
        if endpoint.node is None:
            name, namespace = NODE_NAME_UNKNOWN, NODE_NAMESPACE_UNKNOWN
        else:
            namespace, _, name = endpoint.node.rpartition('/')
            namespace = namespace or '/'
        kinds = {
            EntityKind.PUBLISHER: TopicEndpointType.PUBLISHER,
            EntityKind.SUBSCRIBER: TopicEndpointType.SUBSCRIPTION,
        }
        return cls(
            name,
            namespace,
            endpoint.type_name,
            kinds.get(endpoint.kind, TopicEndpointType.INVALID),
            list(endpoint.gid or b''),
            endpoint.qos,
            endpoint.type_hash or '',
        )
