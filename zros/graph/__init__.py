"""The live view of the ROS graph a session sees: :func:`graph_of` gives a session's
:class:`Graph`, shared by its nodes."""

from zros.graph.endpoint_info import TopicEndpointInfo, TopicEndpointType
from zros.graph.view import REFRESH_CAPACITY, Endpoint, Graph, graph_of
from zros.wire import BridgeInfo, query_bridges

__all__ = [
    'REFRESH_CAPACITY',
    'BridgeInfo',
    'Endpoint',
    'Graph',
    'TopicEndpointInfo',
    'TopicEndpointType',
    'graph_of',
    'query_bridges',
]
