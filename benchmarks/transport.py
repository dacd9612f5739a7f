"""Transport speed: raw zenoh-python against zros, publisher and subscriber in two processes.

Both go through one Zenoh router (started by this script) with the same session settings
(client mode, shared memory off unless ``--shm``); zros runs on the bridge's keys and on
rmw_zenoh's (attachments on every message). Rows, all reliable and keep-all:

  (a) std_msgs/String messages per second, against two raw subscribers: one that only takes
      the bytes, one that also decodes them with zros's codec (and the latter again with a
      publisher that encodes every message, as zros's must); zros with a callback run by
      ``spin_once`` (both wires), with a callback that takes the bytes (``raw=True``: what
      zros adds besides decoding), and read the rosR way (``spin_once`` + ``take()``);
  (b) sensor_msgs/Image 1920x1080 rgb8 throughput in MB/s;
  (c) uint8[] messages (std_msgs/UInt8MultiArray) of 10 B to 10 MB: messages/s and MB/s, raw
      taking the bytes and raw also decoding them (what a subscriber that decodes can reach;
      up to 100 KB also with a publisher that encodes every message);
  (d) ping-pong round trip of std_msgs/Float64 (median and p99), through the router, and between
      peers that met at the router and then talk directly (as DDS nodes do);
  (e) the same round trip through the router with zros on one side only, and raw zenoh-python
      variants (a ping that waits in Rust, an echo that hands over to a spinning thread, echoes
      and a ping in zros's own thread structure with nothing of zros): where zros's extra time
      goes, side by side.

The machine's speed drifts more than the differences being measured (this 2-core VM's String
rates moved by a third within minutes), so competitors never run one after the other: in each
repeat, the processes of every competitor of a row are up at once, on keys of their own, and
they take turns. A throughput row's competitors send 10 turns each (after one to warm up) and
the median turn's rate counts; the round trips of rows d and e take turns of 20. Sequential
runs of 5,000 round trips moved by 30 us from run to run here; the differences between pairs
in one interleaved run, by 2 us. The median of the repeats is reported. The roles are in
``transport_roles.py``.

With the ``interop`` extra and root, the same rows run between two rclpy processes over Fast DDS
inside a private network namespace (``transport_rclpy.py``).

    python benchmarks/transport.py [--quick] [--shm] [--repeats N] [--rows a,b,c,d]

``--against PATH`` runs every zros competitor a second time, named ``... (before)``, with zros
imported from the checkout at PATH (``git worktree add PATH main``), in the same turns: a
change measured against the code before it, on the same machine at the same moments.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import time
from pathlib import Path
from typing import Any

import transport_roles
from transport_rclpy import rclpy_rows
from transport_report import report
from transport_roles import (
    ROLES,
    end_roles,
    publish_turn,
    read_line,
    read_result,
    send_turn,
    spawn_role,
    total,
    twin,
    wait_ready,
    zros_node,
)

__all__ = ['read_result', 'round_trips', 'spawn_role', 'throughput', 'wait_ready', 'zros_node']

STRING_IMPLS = (
    'zenoh',
    'zenoh_decode',
    'zenoh_codec',
    'zenoh_rmw',
    'zros',
    'zros_bytes',
    'zros_rmw',
    'zros_poll',
    'zros_now',
)
IMAGE_IMPLS = ('zenoh', 'zros', 'zros_rmw')
SIZE_IMPLS = ('zenoh', 'zenoh_decode', 'zenoh_codec', 'zros')
RTT_IMPLS = ('zenoh', 'zros', 'zros_rmw', 'zros_now')
#: row e: (echo, ping)
RTT_SPLIT = (
    ('zenoh', 'zenoh'),
    ('zenoh', 'zenoh_fifo'),
    ('zenoh_spin', 'zenoh'),
    ('zenoh_dec', 'zenoh'),
    ('zenoh_spin_dec', 'zenoh'),
    ('zenoh_relay_dec', 'zenoh'),
    ('zros', 'zenoh'),
    ('zenoh_fifo_dec', 'zenoh'),
    ('zros_now', 'zenoh'),
    ('zenoh', 'zenoh_dec'),
    ('zenoh', 'zenoh_relay_dec'),
    ('zenoh', 'zros'),
    ('zros_now', 'zros'),
)
#: raw zenoh-python encoding every message is row (c)'s floor up to this size; beyond it, its
#: fresh buffer per message costs more than zros's publisher, which reuses one
CODEC_FLOOR_SIZES = 100_000
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


#: turns each competitor of a throughput row takes in one run (after one to warm up)
TURNS = 10


def throughputs(
    impls: list[str], kind: str, count: int, endpoint: str, shm: bool
) -> list[dict[str, Any]]:
    """``count`` messages of ``kind`` for each competitor: every competitor's publisher and
    subscriber are up at once, on keys of their own, and they take turns of ``count //``
    :data:`TURNS` messages, so the machine's drift falls on each alike (one competitor runs
    at a time). Returns each one's :func:`total` of its turns."""
    turn = max(count // TURNS, 2)
    subscribers, publishers = [], []
    try:
        for tag, impl in enumerate(impls):
            extra = ['--kind', kind, '--count', str(turn), '--tag', str(tag), '--turns']
            subscribers.append(spawn_role('subscribe', impl, endpoint, extra, shm))
        for process in subscribers:
            wait_ready(process)
        for tag, impl in enumerate(impls):
            extra = ['--kind', kind, '--tag', str(tag), '--turns']
            stdin = subprocess.PIPE
            publishers.append(spawn_role('publish', impl, endpoint, extra, shm, stdin=stdin))
        for process in publishers:
            wait_ready(process)
        turns: list[list[dict[str, Any]]] = [[] for _ in impls]
        for _ in range(TURNS + 1):
            for subscriber, publisher, found in zip(subscribers, publishers, turns, strict=True):
                found.append(publish_turn(publisher, subscriber, turn))
    finally:
        end_roles(publishers + subscribers)
    return [total(found[1:]) for found in turns]  # the first turn warms up


#: round trips a pair makes in one turn (row d, e)
TURN = 20


def round_trips(
    pairs: list[tuple[str, str, bool]], count: int, endpoint: str, shm: bool
) -> list[dict[str, Any]]:
    """``count`` ping-pongs for each (ping, echo, peer) pair: every pair's two processes are up
    at once, on keys of their own, and the pairs take turns of :data:`TURN` round trips, so the
    machine's drift over a run (larger here than the differences measured) falls on each pair
    alike. Returns each pair's median and p99 (seconds)."""
    echoes, pingers = [], []
    try:
        for tag, (_, echo, peer) in enumerate(pairs):
            extra = ['--timeout', '3600', '--tag', str(tag)]
            echoes.append(spawn_role('echo', echo, endpoint, extra, shm, peer=peer))
        for process in echoes:
            wait_ready(process)
        for tag, (ping, _, peer) in enumerate(pairs):
            extra = ['--tag', str(tag)]
            stdin = subprocess.PIPE
            pingers.append(spawn_role('ping', ping, endpoint, extra, shm, peer=peer, stdin=stdin))
        for process in pingers:
            wait_ready(process)
        times: list[list[float]] = [[] for _ in pairs]
        while len(times[0]) < count:
            for process, found in zip(pingers, times, strict=True):
                send_turn(process, TURN)
                found.extend(read_line(process))
    finally:
        end_roles(pingers + echoes)
    results = []
    for found in times:
        found.sort()
        results.append({'median': statistics.median(found), 'p99': found[int(len(found) * 0.99)]})
    return results


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
    parser.add_argument(
        '--against', help='a checkout of zros to run each zros competitor from too (before)'
    )
    parser.add_argument('--role', help=argparse.SUPPRESS)
    parser.add_argument('--impl', default='zros', help=argparse.SUPPRESS)
    parser.add_argument('--endpoint', help=argparse.SUPPRESS)
    parser.add_argument('--kind', default='string', help=argparse.SUPPRESS)
    parser.add_argument('--count', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--timeout', type=float, default=120, help=argparse.SUPPRESS)
    parser.add_argument('--peer', action='store_true', help=argparse.SUPPRESS)
    parser.add_argument('--tag', default='', help=argparse.SUPPRESS)
    parser.add_argument('--turns', action='store_true', help=argparse.SUPPRESS)
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

    if args.against:
        transport_roles.against = str(Path(args.against).resolve())

    def chosen(impls: tuple[str, ...]) -> list[str]:
        names = [impl for impl in impls if impl not in skip]
        return names + [twin(impl) for impl in names if args.against and twin(impl) != impl]

    split_pairs = list(RTT_SPLIT)
    if args.against:
        split_pairs += [(twin(e), twin(p)) for e, p in RTT_SPLIT if 'zros' in e + p]

    def run(row: str, impl: str, found: dict[str, Any]) -> None:
        runs.setdefault(f'{row}/{impl}', []).append(found)

    throughput_rows = []  # (row, kind, competitors, messages)
    if 'a' in rows:
        throughput_rows.append(('string', 'string', chosen(STRING_IMPLS), strings))
    if 'b' in rows:
        throughput_rows.append(('image', 'image', chosen(IMAGE_IMPLS), images))
    if 'c' in rows:
        for size, full in SIZES.items():
            count = max(full // scale, 20)
            impls = [  # beyond CODEC_FLOOR_SIZES, zenoh_codec is no floor for zros
                impl
                for impl in chosen(SIZE_IMPLS)
                if impl != 'zenoh_codec' or size <= CODEC_FLOOR_SIZES
            ]
            throughput_rows.append((f'bytes{size}', f'bytes{size}', impls, count))
    router = start_router(shared_memory=args.shm)
    endpoint = router.endpoint
    try:
        for _ in range(repeats):
            for row, kind, impls, count in throughput_rows:
                results = throughputs(impls, kind, count, endpoint, args.shm)
                for impl, result in zip(impls, results, strict=True):
                    run(row, impl, result)
            if 'd' in rows:
                impls = chosen(RTT_IMPLS)
                pairs = [(impl, impl, peer) for peer in (False, True) for impl in impls]
                results = round_trips(pairs, pings, endpoint, args.shm)
                for (impl, _, peer), result in zip(pairs, results, strict=True):
                    run('rtt_peer' if peer else 'rtt', impl, result)
            if 'e' in rows:
                split = [(ping, echo, False) for echo, ping in split_pairs]
                results = round_trips(split, pings, endpoint, args.shm)
                for (echo, ping), result in zip(split_pairs, results, strict=True):
                    run('split', f'{echo}:{ping}', result)
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
    from readme import recording

    with recording(__file__):
        main()
