"""The graph picture's model, from the live view: zros nodes, a bridge's ROS side, hiding."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from tests.plot.fake_bridge import FakeBridge
from zros.keyexpr.kinds import EntityKind
from zros.plot import GraphModel, Vertex, graph_model

Node = Callable[..., Any]
BRIDGE = '/zenoh_bridge_ros2dds'


def edge(source: str, target: str) -> tuple[Vertex, Vertex]:
    """``'/node'`` -> ``'t/topic'`` style: topics are written with a ``t`` in front."""

    def vertex(name: str) -> Vertex:
        return Vertex('topic', name[1:]) if name.startswith('t/') else Vertex('node', name)

    return vertex(source), vertex(target)


def test_nodes_topics_and_a_bridges_ros_side(zros_node: Node, zros_transport: Any) -> None:
    bridge = FakeBridge(
        zros_transport(),
        [
            (EntityKind.PUBLISHER, '/turtle1/pose', 'turtlesim/msg/Pose'),
            (EntityKind.SUBSCRIBER, '/turtle1/cmd_vel', 'geometry_msgs/msg/Twist'),
            (EntityKind.PUBLISHER, '/rosout', 'rcl_interfaces/msg/Log'),
            (EntityKind.PUBLISHER, '/turtle1/rotate/_action/status', 'action_msgs/msg/GoalStatusArray'),
        ],
    )  # fmt: skip
    try:
        teleop = zros_node('teleop')
        teleop.create_publisher('geometry_msgs/msg/Twist', '/turtle1/cmd_vel')
        follower = zros_node('follower', '/robot')
        follower.create_subscription('geometry_msgs/msg/Pose2D', '/turtle1/pose_2d', lambda m: None)
        follower.create_publisher('geometry_msgs/msg/Point', 'goal')  # /robot/goal
        follower.create_subscription('std_msgs/msg/Empty', '/_internal', lambda m: None)
        follower.get_logger().info('a line on /rosout')
        zros_node('helper', '/_private').create_publisher('std_msgs/msg/Empty', '/_internal')
        observer = zros_node('observer')
        observer.create_subscription('geometry_msgs/msg/Point', '/robot/goal', lambda m: None)

        expected = {
            edge(BRIDGE, 't/turtle1/pose'),
            edge('t/turtle1/cmd_vel', BRIDGE),
            edge('/teleop', 't/turtle1/cmd_vel'),
            edge('t/turtle1/pose_2d', '/robot/follower'),
            edge('/robot/follower', 't/robot/goal'),
        }
        graph = observer.graph

        def found() -> GraphModel:
            return graph_model(observer)

        assert graph.wait_until(lambda: found().edges >= expected, 30), found()
        assert graph.wait_until(lambda: '/_private/helper' in graph.nodes(), 30)
        model = found()
        assert model.edges == expected  # no /rosout, /parameter_events, hidden names, observer
        assert model.nodes == {BRIDGE, '/teleop', '/robot/follower'}
        assert model.bridges == {BRIDGE}
        assert model.topics == {
            '/turtle1/pose': {'turtlesim/msg/Pose'},
            '/turtle1/cmd_vel': {'geometry_msgs/msg/Twist'},
            '/turtle1/pose_2d': {'geometry_msgs/msg/Pose2D'},
            '/robot/goal': {'geometry_msgs/msg/Point'},
        }

        everything = {
            edge(BRIDGE, 't/rosout'),
            edge('/robot/follower', 't/rosout'),
            edge('/teleop', 't/parameter_events'),
            edge(BRIDGE, 't/turtle1/rotate/_action/status'),
            edge('t/_internal', '/robot/follower'),
            edge('/_private/helper', 't/_internal'),
        }

        def unfiltered() -> GraphModel:
            return graph_model(observer, hide_hidden=False, hide_debug=False)

        # hidden and debug entities are discovered at their own pace: wait for them too
        assert graph.wait_until(lambda: everything <= unfiltered().edges, 30), unfiltered()
        shown = unfiltered()
        assert expected < shown.edges
        assert '/observer' not in shown.nodes
        assert not any('/observer' in (a.name, b.name) for a, b in shown.edges)
        # a Graph (not a node) shows every node, the observer too (its own subscription's token
        # reaches its graph as any other does: wait for it, as for the others above)
        assert graph.wait_until(
            lambda: edge('t/robot/goal', '/observer') in graph_model(graph).edges, 30
        )
        assert '/observer' in graph_model(graph).nodes
    finally:
        bridge.close()
