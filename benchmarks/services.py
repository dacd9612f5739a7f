"""Service speed: raw zenoh-python query/reply against zros, client and server in two processes.

Both go through one Zenoh router (started by this script), shared memory off. The service is
std_srvs/srv/SetBool. Rows:

  (a) sequential calls per second (one call in flight);
  (b) the latency of those calls, median and p99;
  (c) calls per second with 8 calls in flight (``call_async`` for zros, callback queries raw).

The raw server replies from Zenoh's callback thread; the zros server runs its handler on the
thread that spins the node, as zros always does. Raw and zros alternate, each row runs a few
times, the median run is reported. With the ``interop`` extra and root, an rclpy client and
server (Fast DDS over UDP inside a private network namespace) give a third column.

    python benchmarks/services.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from typing import Any

from transport_rclpy import dds_namespace
from transport_roles import read_result, wait_ready

HERE = os.path.abspath(__file__)
TYPE = 'std_srvs/srv/SetBool'  #: rclpy from PyPI has std_srvs (example_interfaces is not there)
#: calls in flight in row (c): under the default service QoS depth (10), beyond which DDS
#: servers drop requests
IN_FLIGHT = 8


def _session(endpoint: str) -> Any:
    import zenoh

    settings = {
        'mode': 'client',
        'connect': {'endpoints': [endpoint]},
        'scouting': {'multicast': {'enabled': False}},
        'transport': {'shared_memory': {'enabled': False}},
    }
    return zenoh.open(zenoh.Config.from_json5(json.dumps(settings)))


def _zros_node(name: str, endpoint: str) -> Any:
    import zros
    from zros.transport import Transport, TransportConfig

    config = TransportConfig.create(connect=endpoint, shared_memory=False)
    return zros.Node(name, transport=Transport(config))


# --- worker roles (run in their own processes) ---------------------------------------------------


def role_server(args: argparse.Namespace) -> None:
    """Answer SetBool until killed."""
    import zros
    from zros.cdr import decode, encode

    service_type = zros.get_type(TYPE)
    if args.impl == 'zenoh':
        session = _session(args.endpoint)

        def on_query(query: Any) -> None:
            request = decode(service_type.Request, query.payload.to_bytes())
            with query:
                reply = service_type.Response(success=request.data, message='done')
                query.reply(query.key_expr, encode(reply))

        session.declare_queryable('set_bool', on_query, complete=True)
        print('ready', flush=True)
        threading.Event().wait(args.timeout)
        session.close()
    else:
        node = _zros_node('bench_server', args.endpoint)
        response = service_type.Response

        node.create_service(TYPE, '/set_bool', lambda r: response(success=r.data, message='done'))
        print('ready', flush=True)
        node.spin(timeout=args.timeout)
        node.transport.close()


def role_client(args: argparse.Namespace) -> None:
    """Time ``count`` sequential calls, then ``count`` calls with IN_FLIGHT outstanding."""
    import zros
    from zros.cdr import decode, encode

    service_type = zros.get_type(TYPE)
    request = service_type.Request(data=True)
    times: list[float] = []
    if args.impl == 'zenoh':
        import zenoh

        session = _session(args.endpoint)
        querier = session.declare_querier('set_bool')
        while not querier.matching_status.matching:
            time.sleep(0.001)

        def call() -> None:
            for reply in session.get('set_bool', payload=encode(request), timeout=10):
                decode(service_type.Response, reply.ok.payload.to_bytes())

        def pipelined(count: int) -> None:
            slots = threading.Semaphore(IN_FLIGHT)
            done = threading.Event()
            remaining = [count]
            lock = threading.Lock()

            def on_reply(reply: Any) -> None:
                decode(service_type.Response, reply.ok.payload.to_bytes())

            def on_end() -> None:
                slots.release()
                with lock:
                    remaining[0] -= 1
                    if remaining[0] == 0:
                        done.set()

            for _ in range(count):
                slots.acquire()
                handler = zenoh.handlers.Callback(on_reply, on_end)
                session.get('set_bool', handler, payload=encode(request), timeout=10)
            done.wait(60)

        closer = session.close
    else:
        node = _zros_node('bench_client', args.endpoint)
        client = node.create_client(TYPE, '/set_bool')
        client.wait_for_service(30)

        def call() -> None:
            client.call(request)

        def pipelined(count: int) -> None:
            slots = threading.Semaphore(IN_FLIGHT)
            futures = []
            for _ in range(count):
                slots.acquire()
                future = client.call_async(request)
                future.add_done_callback(lambda _f: slots.release())
                futures.append(future)
            for future in futures:
                future.result(60)

        closer = node.transport.close
    for _ in range(200):
        call()
    for _ in range(args.count):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    start = time.perf_counter()
    pipelined(args.count)
    pipelined_rate = args.count / (time.perf_counter() - start)
    closer()
    times.sort()
    print(
        json.dumps(
            {
                'rate': len(times) / sum(times),
                'median': statistics.median(times),
                'p99': times[int(len(times) * 0.99)],
                'pipelined': pipelined_rate,
            }
        )
    )


# --- the driver ----------------------------------------------------------------------------------


def _spawn(role: str, impl: str, endpoint: str, extra: list[str]) -> subprocess.Popen[str]:
    command = [sys.executable, HERE, '--role', role, '--impl', impl, '--endpoint', endpoint]
    return subprocess.Popen([*command, *extra], stdout=subprocess.PIPE, text=True)


def run(impl: str, count: int, endpoint: str) -> dict[str, Any]:
    server = _spawn('server', impl, endpoint, ['--timeout', '300'])
    wait_ready(server)
    try:
        return read_result(_spawn('client', impl, endpoint, ['--count', str(count)]), 300)
    finally:
        server.kill()
        server.communicate()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true')
    parser.add_argument('--repeats', type=int, default=0, help='runs per row (default 3, 2 quick)')
    parser.add_argument('--role', help=argparse.SUPPRESS)
    parser.add_argument('--impl', default='zros', help=argparse.SUPPRESS)
    parser.add_argument('--endpoint', help=argparse.SUPPRESS)
    parser.add_argument('--count', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--timeout', type=float, default=120, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role:
        {'server': role_server, 'client': role_client}[args.role](args)
        return

    from importlib import metadata

    from zros.transport import start_router

    router = start_router()
    count = 1000 if args.quick else 5000
    repeats = args.repeats or (2 if args.quick else 3)
    print(
        f'zros service benchmark: {TYPE}, client and server in two processes through a '
        f'router, shared memory off, eclipse-zenoh {metadata.version("eclipse-zenoh")}, '
        f'median of {repeats} alternating runs of {count} calls'
    )
    runs: dict[str, list[dict[str, Any]]] = {'zenoh': [], 'zros': []}
    for _ in range(repeats):
        for impl, found in runs.items():
            found.append(run(impl, count, router.endpoint))
    router.close()
    rows = {
        impl: sorted(found, key=lambda r: r['rate'])[len(found) // 2]
        for impl, found in runs.items()
    }
    # rclpy's sequential calls slow down as they accumulate here (0.7 ms at first, 6 ms after
    # 300): a longer run would only measure that
    rclpy = rclpy_row(min(count, 1000))
    if rclpy is not None:
        rows['rclpy'] = rclpy
    report(rows)


def report(rows: dict[str, dict[str, Any]]) -> None:
    z, r, ros = rows['zenoh'], rows['zros'], rows.get('rclpy')
    print()
    print(
        f'{"":32} {"raw zenoh":>10} {"zros":>10} {"zros/raw":>9}'
        + (f' {"rclpy":>10}' if ros else '')
    )
    lines = [
        ('(a) calls/s, one in flight', 'rate', 1.0),
        ('(b) latency median us', 'median', 1e6),
        ('    latency p99 us', 'p99', 1e6),
        (f'(c) calls/s, {IN_FLIGHT} in flight', 'pipelined', 1.0),
    ]
    for label, key, scale in lines:
        raw, ours = z[key] * scale, r[key] * scale
        extra = f' {ros[key] * scale:>10,.0f}' if ros and key in ros else (' ' * 11 if ros else '')
        print(f'{label:32} {raw:>10,.0f} {ours:>10,.0f} {ours / raw:>9.2f}{extra}')
    print()
    goals = [('(a) zros calls/s >= 70 % of raw zenoh', r['rate'] >= 0.7 * z['rate'])]
    if ros:
        goals.append(('zros beats rclpy on (a)', r['rate'] > ros['rate']))
    for text, met in goals:
        print(f'  {"met   " if met else "MISSED"}  {text}')


# --- rclpy over Fast DDS in a private network namespace ----------------------------------------------


RCLPY_WORKER = r"""
import json, statistics, sys, time
import rclpy
from std_srvs.srv import SetBool
role, count, IN_FLIGHT = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rclpy.init()
node = rclpy.create_node('bench_' + role)
if role == 'server':
    def answer(request, response):
        response.success, response.message = request.data, 'done'
        return response
    node.create_service(SetBool, 'set_bool', answer)
    print('ready', flush=True)
    rclpy.spin(node)  # until the driver kills it
else:
    client = node.create_client(SetBool, 'set_bool')
    client.wait_for_service(timeout_sec=30)
    request = SetBool.Request(data=True)
    def call():
        future = client.call_async(request)
        rclpy.spin_until_future_complete(node, future, timeout_sec=10)
        return future.result()
    for _ in range(200):
        call()
    times = []
    for _ in range(count):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    start = time.perf_counter()
    futures = []
    deadline = time.monotonic() + 120
    for i in range(count):
        futures.append(client.call_async(request))
        while sum(not f.done() for f in futures[-IN_FLIGHT:]) >= IN_FLIGHT and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    while not all(f.done() for f in futures) and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    pipelined = sum(f.done() for f in futures) / (time.perf_counter() - start)
    times.sort()
    print(json.dumps({'rate': len(times) / sum(times), 'median': statistics.median(times),
                      'p99': times[int(len(times) * 0.99)], 'pipelined': pipelined}))
node.destroy_node()
rclpy.shutdown()
"""


def rclpy_row(count: int) -> dict[str, Any] | None:
    try:
        import std_srvs  # noqa: F401
    except ImportError:
        print('rclpy column skipped: the interop extra (std-srvs) is missing')
        return None
    with dds_namespace(43, 'rclpy column') as spawn_in:
        if spawn_in is None:
            return None

        def spawn(role: str) -> subprocess.Popen[str]:
            return spawn_in(['-c', RCLPY_WORKER, role, str(count), str(IN_FLIGHT)])

        server = spawn('server')
        wait_ready(server)
        try:
            return read_result(spawn('client'), 300)
        finally:
            server.kill()
            server.communicate()


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()
