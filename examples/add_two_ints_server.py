"""A service server: ``add_two_ints`` (``example_interfaces/srv/AddTwoInts``) adds a and b.

The handler gets the request and returns the response; it runs on the thread that spins the
node (``zros.spin_once()`` below), like subscriber callbacks. A ROS 2 client behind
zenoh-bridge-ros2dds calls it as it would any server::

    ros2 service call /add_two_ints example_interfaces/srv/AddTwoInts "{a: 2, b: 3}"

Start ``add_two_ints_client.py`` on the same router or robot (``--connect`` or
``ZROS_CONNECT``). With neither, this script starts a Zenoh router and calls itself through a
client on a node of its own, to show a few calls.
"""

from __future__ import annotations

import argparse
import threading
import time

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros


def add_two_ints(request: zros.cdr.Message) -> zros.cdr.Message:
    """The service's handler: the sum in a response."""
    print(f'Incoming request: a={request.a} b={request.b}')
    return zros.Message('example_interfaces/srv/AddTwoInts_Response', sum=request.a + request.b)


def call_a_few(stop: threading.Event) -> None:
    """A client on a node of its own (a stand-in for ``add_two_ints_client.py``)."""
    node = zros.Node('add_two_ints_caller')
    client = node.create_client('example_interfaces/srv/AddTwoInts', 'add_two_ints')
    client.wait_for_service(timeout=5)
    for a, b in [(2, 3), (40, 2), (-7, 7)]:
        print(f'  the client got {client.call(a=a, b=b).sum}')
    node.destroy()
    stop.set()


def main() -> int:
    parser = argparse.ArgumentParser(description='serve add_two_ints', formatter_class=ShowDefaults)
    add_connect(parser)
    parser.add_argument('--count', type=int, default=0, help='stop after this many (0: no end)')
    parser.add_argument('--seconds', type=float, default=0, help='stop after this long (0: never)')
    args = parser.parse_args()
    stop = threading.Event()
    router, args.connect = router_unless_given(args.connect, 'a client')

    zros.init('add_two_ints_server', connect=args.connect)
    answered = 0

    def handler(request: zros.cdr.Message) -> zros.cdr.Message:
        nonlocal answered
        answered += 1
        if answered == args.count:
            stop.set()
        return add_two_ints(request)

    zros.Service('add_two_ints', 'example_interfaces/srv/AddTwoInts', handler)
    print('serving add_two_ints')
    if router is not None:
        threading.Thread(target=call_a_few, args=(stop,), daemon=True).start()
    deadline = time.monotonic() + args.seconds if args.seconds else None
    while zros.ok() and not stop.is_set():
        zros.spin_once(timeout=0.1)  # requests are answered in here
        if deadline is not None and time.monotonic() > deadline:
            break
    zros.shutdown()
    if router is not None:
        router.close()
    print(f'answered {answered} requests')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
