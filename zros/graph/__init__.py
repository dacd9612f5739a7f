"""The live view of the ROS graph a session sees: :func:`graph_of` gives a session's
:class:`Graph`, shared by its nodes."""

from zros.graph.view import REFRESH_CAPACITY, Endpoint, Graph, graph_of
from zros.wire import BridgeInfo, query_bridges

__all__ = ['REFRESH_CAPACITY', 'BridgeInfo', 'Endpoint', 'Graph', 'graph_of', 'query_bridges']
