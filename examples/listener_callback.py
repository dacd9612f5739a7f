"""Listener, callback style: the node runs a function for each message, as rclpy does.

The callback runs on the thread that spins the node (here the main thread, in
``zros.spin_once()``), never on one of Zenoh's, so it may touch any state without locks.
``zros.spin()`` would spin until Ctrl-C; this script spins in a loop of its own, until Ctrl-C or
``--count`` messages.

Start ``talker.py`` on the same router or robot (``--connect`` or ``ZROS_CONNECT``). With
neither, this script starts a Zenoh router and a talker timer of its own.
"""

from __future__ import annotations

import argparse
import time

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros


def main() -> int:
    parser = argparse.ArgumentParser(
        description='print what arrives on /chatter, by callback, until Ctrl-C',
        formatter_class=ShowDefaults,
    )
    add_connect(parser)
    parser.add_argument(
        '--count', type=int, default=0, help='messages to wait for (0: until Ctrl-C)'
    )
    parser.add_argument(
        '--seconds', type=float, default=0.0, help='give up after this long (0: never)'
    )
    args = parser.parse_args()
    router, args.connect = router_unless_given(args.connect, 'a talker')

    zros.init('listener', connect=args.connect)
    heard: list[str] = []

    def on_message(message: zros.cdr.Message) -> None:
        heard.append(message.data)
        print(f'I heard: "{message.data}"')

    zros.Subscriber('/chatter', 'std_msgs/msg/String', on_message, qos=10)
    print('listening on /chatter')
    if router is not None:  # a talker on a timer of the same node: it runs while we spin
        pub = zros.Publisher('/chatter', 'std_msgs/msg/String')
        pub.wait_for_subscribers(timeout=5)
        count = iter(range(1_000_000))
        zros.Timer(
            0.1,
            lambda: pub.write(
                zros.Message('std_msgs/msg/String', data=f'Hello World: {next(count)}')
            ),
        )

    deadline = time.monotonic() + args.seconds if args.seconds else float('inf')
    while zros.ok() and (args.count == 0 or len(heard) < args.count):
        if time.monotonic() >= deadline:
            break
        zros.spin_once(timeout=0.1)  # due callbacks and timers run in here
    zros.shutdown()
    if router is not None:
        router.close()
    print(f'heard {len(heard)} messages')
    return 0 if heard else 1


if __name__ == '__main__':
    raise SystemExit(main())
