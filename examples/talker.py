"""Talker: publish ``std_msgs/msg/String`` on ``/chatter``, ten messages a second.

ROS's first tutorial. Start it against a robot's bridge or a router (``--connect tcp/robot:7447``
or ``ZROS_CONNECT``), and a listener on the same network prints what it says:
``listener_polling.py``, ``listener_callback.py``, ``asyncio_subscriber.py``, or
``ros2 topic echo /chatter`` on a ROS machine behind zenoh-bridge-ros2dds. With neither, it
starts a Zenoh router inside itself (where nobody listens) and talks all the same.
"""

from __future__ import annotations

import argparse

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros


def main() -> int:
    parser = argparse.ArgumentParser(
        description='publish hello world on /chatter, until Ctrl-C',
        formatter_class=ShowDefaults,
    )
    add_connect(parser)
    parser.add_argument('--count', type=int, default=0, help='messages to send (0: until Ctrl-C)')
    args = parser.parse_args()
    router, args.connect = router_unless_given(args.connect)

    zros.init('talker', connect=args.connect)
    pub = zros.Publisher('/chatter', 'std_msgs/msg/String')
    if router is None:  # not in a ROS talker: give a listener 2 s to be found, so that the
        found = pub.wait_for_subscribers(timeout=2)  # first messages are not lost
        print('a listener is here' if found else 'nobody listens yet')
    rate = zros.Rate(10)  # sleep() keeps the loop at 10 Hz
    sent = 0
    while zros.ok() and (args.count == 0 or sent < args.count):
        message = zros.Message('std_msgs/msg/String', data=f'Hello World: {sent}')
        pub.write(message)
        print(f'Publishing: "{message.data}"')
        sent += 1
        rate.sleep()
    zros.shutdown()
    if router is not None:
        router.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
