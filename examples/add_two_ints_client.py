"""A service client: call ``add_two_ints`` (``example_interfaces/srv/AddTwoInts``).

``client.call(a=2, b=3)`` builds the request from fields (or takes a request message), waits
for the response and returns it; it needs no spinning, so it also works inside callbacks. A call
raises ``zros.ServiceUnavailableError`` when no server exists, ``zros.ServiceTimeoutError`` when
it does not answer in time, and ``zros.ServiceCallError`` when its handler failed.
``call_async`` returns a future instead, to ``await`` or to ``.result()`` later.

Start ``add_two_ints_server.py`` (or ``ros2 run demo_nodes_py add_two_ints_server`` behind a
bridge) on the same router or robot (``--connect`` or ``ZROS_CONNECT``). With neither, this
script starts a Zenoh router and a server of its own.
"""

from __future__ import annotations

import argparse
import threading

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros


def main() -> int:
    parser = argparse.ArgumentParser(description='call add_two_ints', formatter_class=ShowDefaults)
    add_connect(parser)
    parser.add_argument('a', type=int, nargs='?', default=2)
    parser.add_argument('b', type=int, nargs='?', default=3)
    args = parser.parse_args()
    server_node = None
    router, args.connect = router_unless_given(args.connect, 'a server')

    zros.init('add_two_ints_client', connect=args.connect)
    if router is not None:  # a stand-in for add_two_ints_server.py, spinning on a thread
        server_node = zros.Node('add_two_ints_server')
        server_node.create_service(
            'example_interfaces/srv/AddTwoInts',
            'add_two_ints',
            lambda request: zros.Message(
                'example_interfaces/srv/AddTwoInts_Response', sum=request.a + request.b
            ),
        )
        threading.Thread(target=server_node.spin, daemon=True).start()

    client = zros.Client('add_two_ints', 'example_interfaces/srv/AddTwoInts')
    if not client.wait_for_service(timeout=10):
        print('no add_two_ints server answered within 10 s')
        return 1
    response = client.call(a=args.a, b=args.b, timeout=5)
    print(f'Result of add_two_ints: {args.a} + {args.b} = {response.sum}')

    futures = [client.call_async(a=n, b=n) for n in range(3)]  # three calls in flight at once
    print('and asynchronously:', [future.result(timeout=5).sum for future in futures])
    if server_node is not None:
        server_node.destroy()
    zros.shutdown()
    if router is not None:
        router.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
