"""Listener, polling style: the rosR loop of ``spin_once``, ``has_new_message``, ``take``.

No callback: the program asks the subscriber whether something arrived, when it suits it. The
subscriber holds up to its QoS depth of unread messages (10 here, the newest); ``take()`` returns
them all, oldest first, and ``read_message()`` would give only the newest.

Start ``talker.py`` (or ``ros2 topic pub /chatter std_msgs/msg/String`` behind a bridge) on the
same router or robot (``--connect`` or ``ZROS_CONNECT``). With neither, this script starts a
Zenoh router and a talker of its own, so that there is something to hear.
"""

from __future__ import annotations

import argparse
import threading
import time

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros


def background_talker(stop: threading.Event) -> None:
    """A talker on a node of its own (a stand-in for ``talker.py``), until ``stop`` is set."""
    node = zros.Node('talker')
    pub = node.create_publisher('std_msgs/msg/String', '/chatter')
    pub.wait_for_subscribers(timeout=5)
    rate, count = node.create_rate(10), 0
    while not stop.is_set():
        pub.write(zros.Message('std_msgs/msg/String', data=f'Hello World: {count}'))
        count += 1
        rate.sleep()
    node.destroy()


def main() -> int:
    parser = argparse.ArgumentParser(
        description='print what arrives on /chatter, by polling, until Ctrl-C',
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
    talker = None
    stop = threading.Event()
    router, args.connect = router_unless_given(args.connect, 'a talker')

    zros.init('listener', connect=args.connect)
    sub = zros.Subscriber('/chatter', 'std_msgs/msg/String', qos=10)
    print('listening on /chatter')
    if router is not None:
        talker = threading.Thread(target=background_talker, args=(stop,), daemon=True)
        talker.start()

    heard = 0
    deadline = time.monotonic() + args.seconds if args.seconds else float('inf')
    while zros.ok() and (args.count == 0 or heard < args.count) and time.monotonic() < deadline:
        zros.spin_once(timeout=0.05)  # runs callbacks and timers; there are none here
        if sub.has_new_message():
            for message in sub.take():
                print(f'I heard: "{message.data}"')
                heard += 1
    stop.set()
    if talker is not None:
        talker.join(5)
    zros.shutdown()
    if router is not None:
        router.close()
    print(f'heard {heard} messages')
    return 0 if heard else 1


if __name__ == '__main__':
    raise SystemExit(main())
