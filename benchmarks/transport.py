"""Transport speed: raw zenoh-python against zros, publisher and subscriber in two processes.

Both go through one Zenoh router (started by this script) with the same session settings
(client mode, shared memory off unless ``--shm``); zros runs twice, on the bridge's keys and on
rmw_zenoh's (attachments on every message). Three rows:

  (a) std_msgs/String messages per second (reliable, the subscriber decodes each message);
  (b) sensor_msgs/Image 1920x1080 rgb8 throughput in MB/s;
  (c) ping-pong round trip of std_msgs/Float64 (median and p99), through the router, and between
      peers that met at the router and then talk directly (as DDS nodes do).

Raw zenoh and zros alternate, each row runs a few times, and the median run is reported: the
machine's load drifts more than the differences being measured.

With the ``interop`` extra and root, the same rows run between two rclpy processes over Fast DDS
inside a private network namespace.

    python benchmarks/transport.py [--quick] [--shm]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any

HERE = os.path.abspath(__file__)


# --- worker roles (run in their own processes) ---------------------------------------------------


def _session(endpoint: str, shm: bool, peer: bool = False) -> Any:
    import zenoh

    settings: dict[str, Any] = {
        'mode': 'peer' if peer else 'client',
        'connect': {'endpoints': [endpoint]},
        'scouting': {'multicast': {'enabled': False}},
        'transport': {'shared_memory': {'enabled': shm}},
        'timestamping': {'enabled': True},
    }
    if peer:
        settings['listen'] = {'endpoints': ['tcp/127.0.0.1:0']}
    return zenoh.open(zenoh.Config.from_json5(json.dumps(settings)))


def zros_node(name: str, endpoint: str, shm: bool, peer: bool = False, impl: str = 'zros') -> Any:
    """A zros node on a session of its own (``impl`` 'zros_rmw': on the rmw_zenoh wire)."""
    import zros
    from zros.transport import Transport, TransportConfig

    config = TransportConfig.create(
        connect=endpoint,
        shared_memory=shm,
        mode='peer' if peer else 'client',
        listen='tcp/127.0.0.1:0' if peer else None,
    )
    wire = 'rmw_zenoh' if impl == 'zros_rmw' else 'bridge'
    return zros.Node(name, transport=Transport(config), wire=wire)


def _payload(kind: str) -> Any:
    import numpy as np

    import zros

    if kind == 'string':
        return zros.Message('std_msgs/msg/String', data='hello zros, a short message')
    image = zros.Message(
        'sensor_msgs/msg/Image', height=1080, width=1920, encoding='rgb8', step=5760
    )
    image.data = np.random.default_rng(1).integers(0, 256, 1920 * 1080 * 3, dtype=np.uint8)
    return image


def role_publish(args: argparse.Namespace) -> None:
    """Send ``count`` messages as fast as the transport takes them."""
    message = _payload(args.kind)
    if args.impl == 'zenoh':
        import zenoh

        from zros.cdr import encode

        session = _session(args.endpoint, args.shm)
        publisher = session.declare_publisher(
            'bench/data', congestion_control=zenoh.CongestionControl.BLOCK
        )
        while not publisher.matching_status.matching:
            time.sleep(0.001)
        data = encode(message)
        put = publisher.put
        for _ in range(args.count):
            put(data)
        time.sleep(1)
        session.close()
    else:
        node = zros_node('bench_pub', args.endpoint, args.shm, impl=args.impl)
        publisher = node.create_publisher(message.__msgtype__, '/bench/data', qos='keep_all')
        publisher.wait_for_subscribers(30)
        write = publisher.write
        for _ in range(args.count):
            write(message)
        time.sleep(1)
        node.transport.close()


def role_subscribe(args: argparse.Namespace) -> None:
    """Receive and decode ``count`` messages; print the rate between the first and the last."""
    from zros.cdr import decode, get_class

    cls = get_class('std_msgs/msg/String' if args.kind == 'string' else 'sensor_msgs/msg/Image')
    received = 0
    first = last = 0.0
    size = 0
    if args.impl == 'zenoh':
        import threading

        done = threading.Event()

        def on_sample(sample: Any) -> None:
            nonlocal received, first, last, size
            message = decode(cls, sample.payload.to_bytes())
            now = time.perf_counter()
            if received == 0:
                first = now
                size = len(sample.payload)
            received += 1
            last = now
            if received == args.count:
                done.set()
            del message

        session = _session(args.endpoint, args.shm)
        subscriber = session.declare_subscriber('bench/data', on_sample)
        print('ready', flush=True)
        done.wait(args.timeout)
        subscriber.undeclare()
        session.close()
    else:
        from zros.qos import KEEP_ALL

        node = zros_node('bench_sub', args.endpoint, args.shm, impl=args.impl)

        def on_message(message: Any) -> None:  # the ROS way: callbacks run by spin
            nonlocal received, first, last
            now = time.perf_counter()
            if received == 0:
                first = now
            received += 1
            last = now

        node.create_subscription(cls, '/bench/data', on_message, qos=KEEP_ALL)
        print('ready', flush=True)
        deadline = time.monotonic() + args.timeout
        while received < args.count and time.monotonic() < deadline:
            node.spin_once(0.5)
        size = len(_raw_size(args.kind))
        node.transport.close()
    elapsed = max(last - first, 1e-9)
    print(json.dumps({'received': received, 'rate': (received - 1) / elapsed, 'size': size}))


def _raw_size(kind: str) -> bytes:
    from zros.cdr import encode

    return encode(_payload(kind))


def role_echo(args: argparse.Namespace) -> None:
    """Send every ping back as a pong."""
    if args.impl == 'zenoh':
        import threading

        session = _session(args.endpoint, args.shm, args.peer)
        pong = session.declare_publisher('bench/pong')
        subscriber = session.declare_subscriber('bench/ping', lambda s: pong.put(s.payload))
        print('ready', flush=True)
        threading.Event().wait(args.timeout)
        subscriber.undeclare()
        session.close()
    else:
        node = zros_node('bench_echo', args.endpoint, args.shm, args.peer, args.impl)
        pong = node.create_publisher('std_msgs/msg/Float64', '/bench/pong')
        node.create_subscription('std_msgs/msg/Float64', '/bench/ping', pong.write, qos=100)
        print('ready', flush=True)
        node.spin(timeout=args.timeout)
        node.transport.close()


def role_ping(args: argparse.Namespace) -> None:
    """Measure ``count`` round trips after a warm-up."""
    times: list[float] = []
    if args.impl == 'zenoh':
        import threading

        from zros.cdr import encode

        got = threading.Event()
        session = _session(args.endpoint, args.shm, args.peer)
        session.declare_subscriber('bench/pong', lambda s: got.set())
        ping = session.declare_publisher('bench/ping')
        while not ping.matching_status.matching:
            time.sleep(0.001)
        data = encode(_float(0.0))
        for i in range(args.count + 100):
            got.clear()
            start = time.perf_counter()
            ping.put(data)
            got.wait(2)
            if i >= 100:
                times.append(time.perf_counter() - start)
        session.close()
    else:
        node = zros_node('bench_ping', args.endpoint, args.shm, args.peer, args.impl)
        pongs = node.create_subscription('std_msgs/msg/Float64', '/bench/pong', qos=100)
        ping = node.create_publisher('std_msgs/msg/Float64', '/bench/ping')
        ping.wait_for_subscribers(30)
        message = _float(0.0)
        for i in range(args.count + 100):
            message.data = float(i)
            start = time.perf_counter()
            ping.write(message)
            pongs.wait_for_message(2)
            if i >= 100:
                times.append(time.perf_counter() - start)
        node.transport.close()
    times.sort()
    print(json.dumps({'median': statistics.median(times), 'p99': times[int(len(times) * 0.99)]}))


def _float(value: float) -> Any:
    import zros

    return zros.Message('std_msgs/msg/Float64', data=value)


# --- the driver ----------------------------------------------------------------------------------


def spawn_role(
    role: str, impl: str, endpoint: str, extra: list[str], shm: bool, *, peer: bool = False
) -> subprocess.Popen[str]:
    """This script in another process, playing ``role``."""
    command = [sys.executable, HERE, '--role', role, '--impl', impl, '--endpoint', endpoint, *extra]
    if shm:
        command.append('--shm')
    if peer:
        command.append('--peer')
    return subprocess.Popen(command, stdout=subprocess.PIPE, text=True)


def read_result(process: subprocess.Popen[str], timeout: float) -> dict[str, Any]:
    """The JSON line a role process printed last, once it ended."""
    out, _ = process.communicate(timeout=timeout)
    lines = [line for line in out.splitlines() if line.startswith('{')]
    if process.returncode != 0 or not lines:
        raise RuntimeError(f'a benchmark process failed (exit {process.returncode}): {out[-500:]}')
    return dict(json.loads(lines[-1]))


def wait_ready(process: subprocess.Popen[str]) -> None:
    """Wait until a role process printed ``ready``."""
    assert process.stdout is not None
    line = process.stdout.readline()
    if line.strip() != 'ready':
        raise RuntimeError(f'a benchmark process did not start: {line!r}')


def throughput(impl: str, kind: str, count: int, endpoint: str, shm: bool) -> dict[str, Any]:
    extra = ['--kind', kind, '--count', str(count)]
    subscriber = spawn_role('subscribe', impl, endpoint, extra, shm)
    wait_ready(subscriber)
    publisher = spawn_role('publish', impl, endpoint, extra, shm)
    result = read_result(subscriber, 300)
    publisher.communicate(timeout=60)
    return result


def round_trip(
    impl: str, count: int, endpoint: str, shm: bool, peer: bool = False
) -> dict[str, Any]:
    echo = spawn_role('echo', impl, endpoint, ['--timeout', '300'], shm, peer=peer)
    wait_ready(echo)
    pinger = spawn_role('ping', impl, endpoint, ['--count', str(count)], shm, peer=peer)
    result = read_result(pinger, 300)
    echo.kill()
    echo.communicate()
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true')
    parser.add_argument('--shm', action='store_true', help='allow shared memory (one host)')
    parser.add_argument('--repeats', type=int, default=0, help='runs per row (default 3, 2 quick)')
    parser.add_argument('--role', help=argparse.SUPPRESS)
    parser.add_argument('--impl', default='zros', help=argparse.SUPPRESS)
    parser.add_argument('--endpoint', help=argparse.SUPPRESS)
    parser.add_argument('--kind', default='string', help=argparse.SUPPRESS)
    parser.add_argument('--count', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--timeout', type=float, default=120, help=argparse.SUPPRESS)
    parser.add_argument('--peer', action='store_true', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role:
        roles = {'publish': role_publish, 'subscribe': role_subscribe, 'echo': role_echo}
        roles['ping'] = role_ping
        roles[args.role](args)
        return

    from importlib import metadata

    from zros.transport import start_router

    router = start_router(shared_memory=args.shm)
    strings = 50_000 if args.quick else 200_000
    images = 50 if args.quick else 200
    pings = 1000 if args.quick else 5000
    repeats = args.repeats or (2 if args.quick else 3)
    print(
        f'zros transport benchmark: two processes through a router, shared memory '
        f'{"on" if args.shm else "off"}, eclipse-zenoh {metadata.version("eclipse-zenoh")}, '
        f'median of {repeats} alternating runs'
    )
    impls = ('zenoh', 'zros', 'zros_rmw')
    runs: dict[str, dict[str, list[dict[str, Any]]]] = {
        impl: {'string': [], 'image': [], 'rtt': [], 'rtt_peer': []} for impl in impls
    }
    for _ in range(repeats):
        for impl in impls:
            found = throughput(impl, 'string', strings, router.endpoint, args.shm)
            runs[impl]['string'].append(found)
        for impl in impls:
            found = throughput(impl, 'image', images, router.endpoint, args.shm)
            runs[impl]['image'].append(found)
        for impl in impls:
            runs[impl]['rtt'].append(round_trip(impl, pings, router.endpoint, args.shm))
        for impl in impls:
            found = round_trip(impl, pings, router.endpoint, args.shm, peer=True)
            runs[impl]['rtt_peer'].append(found)
    router.close()
    rows = {
        impl: {row: _median_run(found) for row, found in by_row.items()}
        for impl, by_row in runs.items()
    }
    rclpy = rclpy_rows(args.quick)
    if rclpy is not None:
        rows['rclpy'] = rclpy
    report(rows)


def _median_run(found: list[dict[str, Any]]) -> dict[str, Any]:
    key = 'rate' if 'rate' in found[0] else 'median'
    ordered = sorted(found, key=lambda row: row[key])
    return ordered[len(ordered) // 2]


def report(rows: dict[str, dict[str, dict[str, Any]]]) -> None:
    def mbs(row: dict[str, Any]) -> float:
        return float(row['rate'] * row['size'] / 1e6)

    def us(row: dict[str, Any], key: str) -> float:
        return float(row[key]) * 1e6

    z, r, w = rows['zenoh'], rows['zros'], rows['zros_rmw']
    ros = rows.get('rclpy')
    print()
    header = (
        f'{"":34} {"raw zenoh":>10} {"zros":>10} {"zros/raw":>9} {"rmw_zenoh":>10} {"rmw/raw":>8}'
    )
    print(header + (f' {"rclpy":>10}' if ros else ''))

    def row(key: str, value: Callable[[dict[str, Any]], float]) -> tuple[float, float, float]:
        return value(z[key]), value(r[key]), value(w[key])

    lines = [
        ('(a) String msgs/s', *row('string', lambda x: x['rate']), ros and ros['string']['rate']),
        ('(b) Image 1080p MB/s', *row('image', mbs), ros and mbs(ros['image'])),
        ('(c) Float64 RTT median us, router', *row('rtt', lambda x: us(x, 'median')), None),
        ('    Float64 RTT p99 us, router', *row('rtt', lambda x: us(x, 'p99')), None),
        (
            '    RTT median us, peer to peer',
            *row('rtt_peer', lambda x: us(x, 'median')),
            ros and us(ros['rtt'], 'median'),
        ),
        (
            '    RTT p99 us, peer to peer',
            *row('rtt_peer', lambda x: us(x, 'p99')),
            ros and us(ros['rtt'], 'p99'),
        ),
    ]
    for label, raw, ours, rmw, theirs in lines:
        extra = f' {theirs:>10,.0f}' if theirs else (' ' * 11 if ros else '')
        print(
            f'{label:34} {raw:>10,.0f} {ours:>10,.0f} {ours / raw:>9.2f} {rmw:>10,.0f} '
            f'{rmw / raw:>8.2f}{extra}'
        )
    print()
    goals = [
        ('(a) String rate >= 50 % of raw zenoh', r['string']['rate'] >= 0.5 * z['string']['rate']),
        ('(b) Image MB/s >= 80 % of raw zenoh', mbs(r['image']) >= 0.8 * mbs(z['image'])),
        ('(c) median RTT <= raw + 30 us', r['rtt']['median'] <= z['rtt']['median'] + 30e-6),
    ]
    if ros:
        goals.append(('zros beats rclpy on (a)', r['string']['rate'] > ros['string']['rate']))
        goals.append(
            (
                'zros beats rclpy on (c), both peer to peer',
                r['rtt_peer']['median'] < ros['rtt']['median'],
            )
        )
    for text, met in goals:
        print(f'  {"met   " if met else "MISSED"}  {text}')
    received = {impl: row['string']['received'] for impl, row in rows.items()}
    print(f'  messages received in (a): {received} (none may be lost)')


# --- rclpy over Fast DDS in a private network namespace ----------------------------------------------


RCLPY_WORKER = r"""
import json, statistics, sys, time, threading
import numpy as np
import rclpy
from rclpy.qos import QoSProfile, HistoryPolicy, ReliabilityPolicy
from std_msgs.msg import String, Float64
from sensor_msgs.msg import Image
role, count = sys.argv[1], int(sys.argv[2])
rclpy.init()
node = rclpy.create_node('bench_' + role)
keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
if role in ('pub_string', 'pub_image'):
    msg_type = String if role == 'pub_string' else Image
    pub = node.create_publisher(msg_type, 'bench', keep_all)
    msg = msg_type()
    if msg_type is String:
        msg.data = 'hello zros, a short message'
    else:
        msg.height, msg.width, msg.encoding, msg.step = 1080, 1920, 'rgb8', 5760
        msg.data = np.random.default_rng(1).integers(0, 256, 1920 * 1080 * 3, dtype=np.uint8).tobytes()
    while pub.get_subscription_count() == 0:
        time.sleep(0.01)
    time.sleep(0.5)
    for _ in range(count):
        pub.publish(msg)
    time.sleep(2)
elif role in ('sub_string', 'sub_image'):
    msg_type = String if role == 'sub_string' else Image
    state = {'n': 0, 'first': 0.0, 'last': 0.0}
    def on(msg):
        now = time.perf_counter()
        if state['n'] == 0:
            state['first'] = now
        state['n'] += 1
        state['last'] = now
    node.create_subscription(msg_type, 'bench', on, keep_all)
    print('ready', flush=True)
    deadline = time.monotonic() + 120
    while state['n'] < count and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    size = 1920 * 1080 * 3 + 64 if msg_type is Image else 36
    print(json.dumps({'received': state['n'], 'rate': (state['n'] - 1) / max(state['last'] - state['first'], 1e-9), 'size': size}))
elif role == 'echo':
    pub = node.create_publisher(Float64, 'pong', 10)
    node.create_subscription(Float64, 'ping', pub.publish, 10)
    print('ready', flush=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
elif role == 'ping':
    got = []
    node.create_subscription(Float64, 'pong', got.append, 10)
    pub = node.create_publisher(Float64, 'ping', 10)
    while pub.get_subscription_count() == 0:
        time.sleep(0.01)
    time.sleep(0.5)
    times = []
    msg = Float64()
    for i in range(count + 100):
        got.clear()
        start = time.perf_counter()
        pub.publish(msg)
        while not got:
            rclpy.spin_once(node, timeout_sec=1.0)
        if i >= 100:
            times.append(time.perf_counter() - start)
    times.sort()
    print(json.dumps({'median': statistics.median(times), 'p99': times[int(len(times) * 0.99)]}))
node.destroy_node()
rclpy.shutdown()
"""


def rclpy_rows(quick: bool) -> dict[str, dict[str, Any]] | None:
    try:
        import rclpy  # noqa: F401
    except ImportError:
        print('rclpy row skipped: the interop extra (ros-jazzy-rclpy) is not installed')
        return None
    if os.geteuid() != 0 or shutil.which('ip') is None:
        print('rclpy row skipped: a private network namespace for DDS needs root and iproute2')
        return None
    namespace = f'zros_bench_{os.getpid()}'
    subprocess.run(['ip', 'netns', 'add', namespace], check=True)
    try:
        subprocess.run(['ip', '-n', namespace, 'link', 'set', 'lo', 'up'], check=True)
        env = {
            **os.environ,
            'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp',
            'ROS_DOMAIN_ID': '42',
            'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4',  # like zros here: no shared memory
        }

        def spawn(role: str, count: int) -> subprocess.Popen[str]:
            return subprocess.Popen(
                [
                    'ip',
                    'netns',
                    'exec',
                    namespace,
                    sys.executable,
                    '-c',
                    RCLPY_WORKER,
                    role,
                    str(count),
                ],
                stdout=subprocess.PIPE,
                text=True,
                env=env,
            )

        rows: dict[str, dict[str, Any]] = {}
        for kind, count in (
            ('string', 20_000 if quick else 100_000),
            ('image', 50 if quick else 100),
        ):
            subscriber = spawn(f'sub_{kind}', count)
            wait_ready(subscriber)
            publisher = spawn(f'pub_{kind}', count)
            rows[kind] = read_result(subscriber, 300)
            publisher.communicate(timeout=120)
        echo = spawn('echo', 0)
        wait_ready(echo)
        rows['rtt'] = read_result(spawn('ping', 1000 if quick else 5000), 300)
        echo.kill()
        echo.communicate()
        return rows
    finally:
        subprocess.run(['ip', 'netns', 'del', namespace], check=False)


if __name__ == '__main__':
    main()
