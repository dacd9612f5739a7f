"""Transport speed: raw zenoh-python against zros, publisher and subscriber in two processes.

Both go through one Zenoh router (started by this script) with the same session settings
(client mode, shared memory off unless ``--shm``); zros runs on the bridge's keys and on
rmw_zenoh's (attachments on every message). Rows, all reliable and keep-all:

  (a) std_msgs/String messages per second, against two raw subscribers: one that only takes
      the bytes, one that also decodes them with zros's codec; zros with a callback run by
      ``spin_once`` (both wires), with a callback that takes the bytes (``raw=True``: what
      zros adds besides decoding), and read the rosR way (``spin_once`` + ``take()``);
  (b) sensor_msgs/Image 1920x1080 rgb8 throughput in MB/s;
  (c) uint8[] messages (std_msgs/UInt8MultiArray) of 10 B to 10 MB: messages/s and MB/s, raw
      taking the bytes and raw also decoding them (what a subscriber that decodes can reach);
  (d) ping-pong round trip of std_msgs/Float64 (median and p99), through the router, and between
      peers that met at the router and then talk directly (as DDS nodes do);
  (e) the same round trip through the router with zros on one side only, and raw zenoh-python
      variants (a ping that waits in Rust, an echo that hands over to a spinning thread): where
      zros's extra time goes, side by side.

Competitors alternate within each repeat, and the median run is reported: the machine's load
drifts more than the differences being measured. The roles are in ``transport_roles.py``.

With the ``interop`` extra and root, the same rows run between two rclpy processes over Fast DDS
inside a private network namespace (``transport_rclpy.py``).

    python benchmarks/transport.py [--quick] [--shm] [--repeats N] [--rows a,b,c,d]
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from transport_rclpy import rclpy_rows
from transport_report import report
from transport_roles import ROLES, read_result, spawn_role, wait_ready, zros_node

__all__ = ['read_result', 'round_trip', 'spawn_role', 'throughput', 'wait_ready', 'zros_node']

STRING_IMPLS = (
    'zenoh',
    'zenoh_decode',
    'zenoh_rmw',
    'zros',
    'zros_bytes',
    'zros_rmw',
    'zros_poll',
    'zros_now',
)
IMAGE_IMPLS = ('zenoh', 'zros', 'zros_rmw')
SIZE_IMPLS = ('zenoh', 'zenoh_decode', 'zros')
RTT_IMPLS = ('zenoh', 'zros', 'zros_rmw', 'zros_now')
#: row e: (echo, ping)
RTT_SPLIT = (
    ('zenoh', 'zenoh'),
    ('zenoh', 'zenoh_fifo'),
    ('zenoh_spin', 'zenoh'),
    ('zros', 'zenoh'),
    ('zros_now', 'zenoh'),
    ('zenoh', 'zros'),
    ('zros_now', 'zros'),
)
#: uint8[] sizes of row (c), and how many messages each run sends (full run)
SIZES = {
    10: 200_000,
    100: 200_000,
    1_000: 100_000,
    10_000: 50_000,
    100_000: 10_000,
    1_000_000: 1_000,
    10_000_000: 100,
}


def throughput(impl: str, kind: str, count: int, endpoint: str, shm: bool) -> dict[str, Any]:
    """One subscriber and one publisher of ``impl`` passing ``count`` messages of ``kind``."""
    extra = ['--kind', kind, '--count', str(count)]
    subscriber = spawn_role('subscribe', impl, endpoint, extra, shm)
    wait_ready(subscriber)
    cpu = time.process_time()  # this process's: the router's, when it runs one
    publisher = spawn_role('publish', impl, endpoint, extra, shm)
    result = read_result(subscriber, 300)
    result['cpu_publisher'] = read_result(publisher, 60)['cpu']
    result['cpu_router'] = time.process_time() - cpu
    return result


def round_trip(
    impl: str, count: int, endpoint: str, shm: bool, *, peer: bool = False, echo_impl: str = ''
) -> dict[str, Any]:
    """``count`` ping-pongs between two processes of ``impl`` (the echo's: ``echo_impl``)."""
    echo_role = echo_impl or impl
    echo = spawn_role('echo', echo_role, endpoint, ['--timeout', '300'], shm, peer=peer)
    wait_ready(echo)
    pinger = spawn_role('ping', impl, endpoint, ['--count', str(count)], shm, peer=peer)
    result = read_result(pinger, 300)
    echo.kill()
    echo.communicate()
    return result


def parse() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=(__doc__ or '').splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='fewer messages, one run per row')
    parser.add_argument('--shm', action='store_true', help='allow shared memory (one host)')
    parser.add_argument('--repeats', type=int, default=0, help='runs per row (default 3, 1 quick)')
    parser.add_argument('--rows', default='a,b,c,d,e', help='which rows to run (default all)')
    parser.add_argument(
        '--skip', default='', help='competitors to leave out, e.g. zros_now (for older zros)'
    )
    parser.add_argument('--no-rclpy', action='store_true', help='leave out the rclpy rows')
    parser.add_argument('--role', help=argparse.SUPPRESS)
    parser.add_argument('--impl', default='zros', help=argparse.SUPPRESS)
    parser.add_argument('--endpoint', help=argparse.SUPPRESS)
    parser.add_argument('--kind', default='string', help=argparse.SUPPRESS)
    parser.add_argument('--count', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--timeout', type=float, default=120, help=argparse.SUPPRESS)
    parser.add_argument('--peer', action='store_true', help=argparse.SUPPRESS)
    return parser.parse_args()


def main() -> None:
    args = parse()
    if args.role:
        ROLES[args.role](args)
        return

    from importlib import metadata

    from zros.transport import start_router

    rows = set(args.rows.split(','))
    scale = 4 if args.quick else 1
    strings = 200_000 // scale
    images = 200 // scale
    pings = 5000 // scale
    repeats = args.repeats or (1 if args.quick else 3)
    print(
        f'zros transport benchmark: two processes through a router, shared memory '
        f'{"on" if args.shm else "off"}, eclipse-zenoh {metadata.version("eclipse-zenoh")}, '
        f'median of {repeats} alternating runs'
    )
    runs: dict[str, list[dict[str, Any]]] = {}
    skip = set(args.skip.split(','))

    def chosen(impls: tuple[str, ...]) -> list[str]:
        return [impl for impl in impls if impl not in skip]

    def run(row: str, impl: str, found: dict[str, Any]) -> None:
        runs.setdefault(f'{row}/{impl}', []).append(found)

    router = start_router(shared_memory=args.shm)
    endpoint = router.endpoint
    try:
        for _ in range(repeats):
            if 'a' in rows:
                for impl in chosen(STRING_IMPLS):
                    run('string', impl, throughput(impl, 'string', strings, endpoint, args.shm))
            if 'b' in rows:
                for impl in chosen(IMAGE_IMPLS):
                    run('image', impl, throughput(impl, 'image', images, endpoint, args.shm))
            if 'c' in rows:
                for size, full in SIZES.items():
                    count = max(full // scale, 20)
                    for impl in chosen(SIZE_IMPLS):
                        found = throughput(impl, f'bytes{size}', count, endpoint, args.shm)
                        run(f'bytes{size}', impl, found)
            if 'd' in rows:
                for impl in chosen(RTT_IMPLS):
                    run('rtt', impl, round_trip(impl, pings, endpoint, args.shm))
                for impl in chosen(RTT_IMPLS):
                    run('rtt_peer', impl, round_trip(impl, pings, endpoint, args.shm, peer=True))
            if 'e' in rows:
                for echo, ping in RTT_SPLIT:
                    found = round_trip(ping, pings, endpoint, args.shm, echo_impl=echo)
                    run('split', f'{echo}:{ping}', found)
    finally:
        router.close()
    medians = {key: _median_run(found) for key, found in runs.items()}
    rclpy = rclpy_rows(args.quick) if {'a', 'b', 'd'} <= rows and not args.no_rclpy else None
    report(medians, rclpy)


def _median_run(found: list[dict[str, Any]]) -> dict[str, Any]:
    key = 'rate' if 'rate' in found[0] else 'median'
    ordered = sorted(found, key=lambda row: row[key])
    median = dict(ordered[len(ordered) // 2])
    median['runs'] = [row[key] for row in found]
    median['lost'] = sum(row.get('expected', 0) - row.get('received', 0) for row in found)
    if key == 'median':
        median['p99'] = sorted(row['p99'] for row in found)[len(found) // 2]
    return median


if __name__ == '__main__':
    main()
