"""A zros node (:class:`Node`): a ROS name on the Zenoh network that owns publishers,
subscribers, services, actions, timers and parameters."""

from zros.node.facade import Node
from zros.node.graph_methods import NodeNameNonExistentError

__all__ = ['Node', 'NodeNameNonExistentError']
