"""Connect to a real robot through zenoh-bridge-ros2dds, and look around.

On the robot, zenoh-bridge-ros2dds joins the ROS 2 graph over DDS and listens for Zenoh on port
7447; zros on any other machine connects to it as a Zenoh client. This script connects to
``--connect``, else ``ZROS_CONNECT``, else ``tcp/127.0.0.1:7447`` (a bridge on this machine),
then lists the bridges found (version, ROS namespace), the topics they bridge, and prints a
message from ``--topic`` if asked.

When nothing answers there, it prints how to set a bridge up: on the robot, or a stand-in robot
in Docker (``robot_compose.yml`` beside this script: ROS 2's demo talker behind the official
bridge image), and exits without error.
"""

from __future__ import annotations

import argparse
import os

from _bootstrap import ShowDefaults

import zros

DEFAULT = 'tcp/127.0.0.1:7447'

SETUP = """\
No bridge answered at {where}:
  {reason}

To reach a robot, run zenoh-bridge-ros2dds on it, beside its ROS 2 nodes (same ROS_DOMAIN_ID):
  docker run --init --net host -e ROS_DOMAIN_ID=$ROS_DOMAIN_ID eclipse/zenoh-bridge-ros2dds:1.10.0
  (or the standalone zenoh-bridge-ros2dds binary of the same version)
then, on this machine:
  python examples/real_robot.py --connect tcp/<robot address>:7447 --topic /chatter

No robot at hand? A stand-in in Docker, ROS 2 Jazzy's demo talker behind the bridge:
  docker compose -f examples/robot_compose.yml up -d
  python examples/real_robot.py --topic /chatter
Bridged ROS services need ROS nodes on rmw_cyclonedds_cpp; across the internet, see wan_tls.py."""


def main() -> int:
    parser = argparse.ArgumentParser(
        description='connect to a robot through its bridge', formatter_class=ShowDefaults
    )
    parser.add_argument('--connect', help=f'the bridge (default: $ZROS_CONNECT, else {DEFAULT})')
    parser.add_argument('--topic', help='print one message of this topic')
    parser.add_argument('--timeout', type=float, default=5.0, help='seconds to wait for it')
    args = parser.parse_args()
    where = args.connect or os.environ.get('ZROS_CONNECT') or DEFAULT
    try:
        node = zros.init('zros_inspector', connect=where)
    except zros.TransportError as unreachable:  # nothing listening, refused, bad certificate...
        print(SETUP.format(where=where, reason=unreachable))
        return 0

    print(f'connected to {where}')
    node.graph.refresh(timeout=2)  # ask for every token now, and each bridge for its version
    bridges = node.graph.bridges()
    for bridge in bridges:
        print(f'  bridge {bridge.zid}: version {bridge.version}, namespace {bridge.namespace}')
    if not bridges:
        print('  no zenoh-bridge-ros2dds answered: a plain Zenoh router, or zros nodes only')
    topics = node.get_topic_names_and_types()
    print(f'{len(topics)} topics:')
    for topic, types in topics:
        print(f'  {topic} [{", ".join(types)}]')
    if args.topic:
        found = dict(topics).get(args.topic)
        if not found:
            print(f'{args.topic} is not on the network')
        else:
            sub = zros.Subscriber(args.topic, found[0])
            message = sub.wait_for_message(timeout=args.timeout)
            print(f'{args.topic}: {message}' if message else f'nothing on {args.topic} in time')
    zros.shutdown()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
