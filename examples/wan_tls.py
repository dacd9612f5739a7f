"""A laptop reaching a robot across the internet: Zenoh client mode, mutual TLS.

Over a WAN the laptop is a Zenoh *client* of the robot's router (zenoh-bridge-ros2dds is one):
it dials out, needs no open port of its own, and all its traffic crosses one TLS link. With
mutual TLS the router also checks the laptop's certificate, so only machines you gave one can
join. The setup for real, with a CA of your own (``pip install '.[tls]'`` in a checkout)::

    zros tls init certs --host robot.example.org --client laptop
    # on the robot:  zenoh-bridge-ros2dds -c certs/router.json5
    # on the laptop: the export lines it prints (ZROS_CONNECT=tls/robot.example.org:7447,
    #                ZROS_TLS_CA, ZROS_TLS_CERTIFICATE, ZROS_TLS_KEY), then any zros program:
    python wan_tls.py          # with ZROS_CONNECT set it connects there and lists the topics

With no ``ZROS_CONNECT``, this script plays the whole setup on loopback: it makes a CA and
certificates in a temporary folder (what ``zros tls init`` does), starts a router that listens
for TLS only (the robot's), connects a robot node and the laptop to it with their own
certificates, sends a command one way and a battery reading the other, and shows what a machine
without a certificate is told.
"""

from __future__ import annotations

import argparse
import os
import tempfile

from _bootstrap import ShowDefaults

import zros
from zros.transport import Tls, Transport, TransportConfig, TransportError


def on_loopback(folder: str) -> int:
    """The robot's router and both ends in this process, over TLS on 127.0.0.1."""
    try:
        from zros.transport.pki import make_certificates

        certs = make_certificates(folder, hosts=['localhost'], clients=['laptop', 'robot'])
    except zros.ZrosError as missing:  # no cryptography package: the tls extra
        print(f'cannot make certificates here: {missing}')
        return 1
    print(f'made a CA, a router certificate for "localhost" and two client ones in {folder}')

    robot_router = zros.start_router('tls/127.0.0.1:0', zenoh=certs.router_settings(mutual=True))
    # the certificate names "localhost": dial that name, not the address
    endpoint = robot_router.endpoint.replace('127.0.0.1', 'localhost')
    print(f"the robot's router listens on {endpoint}, TLS only, client certificates required")

    robot_session = Transport(
        TransportConfig.create(connect=endpoint, tls=certs.client_tls('robot'))
    )
    robot = zros.Node(
        'robot', transport=robot_session
    )  # on the robot: a ROS node behind the bridge
    commands = robot.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel')
    battery = robot.create_publisher('sensor_msgs/msg/BatteryState', '/battery', qos='latched')
    battery.write(zros.Message('sensor_msgs/msg/BatteryState', voltage=24.3, percentage=0.87))

    laptop = zros.init('laptop', connect=endpoint, mode='client', tls=certs.client_tls('laptop'))
    print(f'the laptop connected as a Zenoh client: {laptop.transport.connected}')
    state = zros.Subscriber('/battery', 'sensor_msgs/msg/BatteryState', qos='latched')
    drive = zros.Publisher('/cmd_vel', 'geometry_msgs/msg/Twist')
    reading = state.wait_for_message(timeout=5)
    print(f'laptop <- robot: battery at {reading.voltage:.1f} V, {reading.percentage:.0%}')
    drive.wait_for_subscribers(timeout=5)
    drive.write(zros.Message('geometry_msgs/msg/Twist', linear={'x': 0.2}))
    command = commands.wait_for_message(timeout=5)
    print(f'laptop -> robot: cmd_vel linear.x = {command.linear.x}')

    try:  # a machine that has the CA but no client certificate of its own
        Transport(TransportConfig.create(connect=endpoint, tls=Tls(str(certs.ca))))
    except TransportError as refused:
        print(f'a machine without a client certificate is refused:\n  {refused}')

    robot_config = certs.router_config('tls/[::]:7447', mutual=True)  # zros tls init writes it
    print(
        f"the robot's zenoh-bridge-ros2dds -c router.json5: {len(robot_config.splitlines())} "
        'lines, certificates inline'
    )
    zros.shutdown()
    robot.destroy()
    robot_session.close()
    robot_router.close()
    return 0


def to_a_robot(connect: str | None) -> int:
    """Connect where ZROS_CONNECT (or --connect) says, with the ZROS_TLS_* files, and look."""
    try:
        node = zros.init('laptop', connect=connect)
    except TransportError as refused:
        print(f'could not connect:\n  {refused}')
        return 1
    print(f'connected to {connect or os.environ["ZROS_CONNECT"]}')
    node.wait_for_publishers('/rosout', timeout=2)  # give the graph a moment to fill in
    for topic, types in node.get_topic_names_and_types():
        print(f'  {topic} [{", ".join(types)}]')
    zros.shutdown()
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(
        description='a laptop to a robot over TLS', formatter_class=ShowDefaults
    )
    parser.add_argument('--connect', help='the robot, e.g. tls/robot.example.org:7447')
    args = parser.parse_args()
    if args.connect or os.environ.get('ZROS_CONNECT'):
        return to_a_robot(args.connect)
    with tempfile.TemporaryDirectory(prefix='zros-certs-') as folder:
        return on_loopback(folder)


if __name__ == '__main__':
    raise SystemExit(main())
