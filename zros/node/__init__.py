"""A zros node (:class:`Node`): a ROS name on the Zenoh network that owns publishers,
subscribers, services, actions, timers and parameters."""

from zros.node.facade import Node

__all__ = ['Node']
