"""Make the README's pictures from a scripted scene, with the code the README shows.

    python docs/images/make_images.py          # writes live_plot.png and graph.png here

A router runs inside this script. A stand-in for a robot's zenoh-bridge-ros2dds announces what
the bridge announces for the robot's ROS nodes (its liveliness tokens and admin space) and
publishes their data: an IMU at 100 Hz (a 0.5 Hz sway in x with sensor noise) and odometry at
20 Hz (a speed ramping up and down). zros nodes teleoperate, filter the commands against the
laser scan, and log speeds. Then:

* ``live_plot.png``: ``zros.plot.live`` of ``/imu/linear_acceleration/x`` and
  ``/odom/twist/twist/linear/x`` with a moving average of 10, a 6 s window, after 8 s;
* ``graph.png``: ``zros.plot.graph`` of what a node sees of the graph (as ``zros graph`` draws it).

The noise is seeded; the times are real, so two runs differ by their arrival times only.
"""

from __future__ import annotations

import json
import math
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

import zros
import zros.plot
from zros.cdr import encode
from zros.keyexpr.bridge import EntityKind, EntityToken, TokenQoS
from zros.plot.graph_layout import layout_graph
from zros.plot.graph_picture import draw_graph, font_measure, graph_model, save_figure
from zros.transport import Transport, TransportConfig

HERE = Path(__file__).resolve().parent
#: what the robot's ROS nodes publish (MP) and subscribe to (MS), seen through its bridge
ROBOT = [
    (EntityKind.PUBLISHER, '/imu', 'sensor_msgs/msg/Imu'),
    (EntityKind.PUBLISHER, '/odom', 'nav_msgs/msg/Odometry'),
    (EntityKind.PUBLISHER, '/scan', 'sensor_msgs/msg/LaserScan'),
    (EntityKind.PUBLISHER, '/tf', 'tf2_msgs/msg/TFMessage'),
    (EntityKind.SUBSCRIBER, '/cmd_vel', 'geometry_msgs/msg/Twist'),
    (EntityKind.PUBLISHER, '/rosout', 'rcl_interfaces/msg/Log'),  # hidden in the picture
]


def stand_in_bridge(endpoint: str) -> tuple[Transport, list[Any]]:
    """A session that announces itself and the robot's entities as a bridge does."""
    transport = Transport(TransportConfig.create(connect=endpoint, shared_memory=False))
    session, zid = transport.session, transport.zid

    def admin(query: Any) -> None:
        item = str(query.key_expr).rsplit('/', 1)[-1]
        with query:
            if item == 'version':
                query.reply(f'@/{zid}/ros2/version', json.dumps('v1.10.0'))
            elif item == 'config':
                config = {'namespace': '/', 'nodename': 'zenoh_bridge_ros2dds'}
                query.reply(f'@/{zid}/ros2/config', json.dumps(config))

    keep: list[Any] = [session.declare_queryable(f'@/{zid}/ros2/**', admin)]
    keys = [f'@/{zid}/@ros2_lv']
    for kind, name, type_name in ROBOT:
        qos = TokenQoS.from_qos(zros.QoS(10)) if kind.has_qos else None
        keys.append(EntityToken(kind, zid, name[1:], type_name, qos).format())
    keep += [session.liveliness().declare_token(key) for key in keys]
    return transport, keep


def robot_data(transport: Transport, stop: threading.Event) -> None:
    """The robot's sensors as its bridge forwards them (CDR on the topic's key): /imu at 100 Hz,
    /odom at 20 Hz, until ``stop``."""
    session = transport.session
    imu_key, odom_key = session.declare_publisher('imu'), session.declare_publisher('odom')
    noise = np.random.default_rng(7)
    started = time.monotonic()
    for tick in range(1_000_000):
        if stop.wait(max(0.0, started + tick / 100 - time.monotonic())):
            break
        t = tick / 100
        imu = zros.Message('sensor_msgs/msg/Imu')
        imu.linear_acceleration.x = 0.8 * math.sin(2 * math.pi * 0.5 * t) + noise.normal(0, 0.2)
        imu.linear_acceleration.z = 9.81 + noise.normal(0, 0.05)
        imu_key.put(encode(imu))
        if tick % 5 == 0:
            odom = zros.Message('nav_msgs/msg/Odometry')
            odom.twist.twist.linear.x = 0.6 * (1 - math.cos(2 * math.pi * t / 8)) / 2
            odom_key.put(encode(odom))
    imu_key.undeclare()
    odom_key.undeclare()


def main() -> None:
    router = zros.start_router(shared_memory=False)
    bridge, announced = stand_in_bridge(router.endpoint)
    nodes: list[zros.Node] = []
    sessions: list[Transport] = []

    def node(name: str, namespace: str = '/') -> zros.Node:
        # a session each, as each would have in a process of its own
        session = Transport(TransportConfig.create(connect=router.endpoint, shared_memory=False))
        made = zros.Node(name, namespace, transport=session)
        sessions.append(session)
        nodes.append(made)
        return made

    teleop = node('teleop')
    teleop.create_publisher('geometry_msgs/msg/Twist', '/cmd_vel_raw')
    safety = node('safety_filter')
    safety.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel_raw', lambda m: None)
    safety.create_subscription('sensor_msgs/msg/LaserScan', '/scan', lambda m: None)
    safety.create_publisher('geometry_msgs/msg/Twist', '/cmd_vel')
    stats = node('speed_stats', '/analysis')
    stats.create_subscription('nav_msgs/msg/Odometry', '/odom', lambda m: None)
    stats.create_publisher('std_msgs/msg/Float64', 'speed')  # /analysis/speed
    dashboard = node('dashboard', '/analysis')
    dashboard.create_subscription('std_msgs/msg/Float64', 'speed', lambda m: None)
    dashboard.create_subscription('sensor_msgs/msg/Imu', '/imu', lambda m: None)
    plotter = node('zros_plot')

    stop = threading.Event()
    sensors = threading.Thread(target=robot_data, args=(bridge, stop), daemon=True)
    sensors.start()
    try:
        zros.plot.live(
            ['/imu/linear_acceleration/x', '/odom/twist/twist/linear/x'],
            node=plotter,
            window=6.0,
            filter=10,
            duration=8.0,
            png=HERE / 'live_plot.png',
        )
        print(f'wrote {HERE / "live_plot.png"}')
        plotter.destroy()  # its subscriptions ended with the plot
        observer = node('observer')
        graph = observer.graph
        graph.refresh()
        graph.wait_until(lambda: len(graph_model(observer).edges) >= 13, 5.0)
        model = graph_model(observer)
        figure = draw_graph(layout_graph(model, font_measure()), model)
        save_figure(figure, HERE / 'graph.png', dpi=120)
        print(f'wrote {HERE / "graph.png"}: {len(model.nodes)} nodes, {len(model.topics)} topics')
    finally:
        stop.set()
        sensors.join()
        for made in nodes:
            made.destroy()
        for session in sessions:
            session.close()
        for entity in announced:
            entity.undeclare()
        bridge.close()
        router.close()


if __name__ == '__main__':
    main()
