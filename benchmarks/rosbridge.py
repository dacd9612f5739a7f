"""rosbridge speed: messages through ``zros rosbridge`` to a WebSocket client, in JSON and in
CBOR, against zros's own subscriber, in the same run.

A publisher process (the one of ``benchmarks/transport.py``) sends as fast as the transport
takes; the messages go through a router (started here) to

  * a zros subscriber process (callbacks, as ``transport.py`` measures it), or
  * the ``zros rosbridge`` command in a process of its own, to a client process (the
    websockets library) that subscribes with ``compression`` none (JSON) or ``cbor``, decodes
    every message as a web client must (``json.loads``, ``cbor2.loads``) and counts it.

Rows: std_msgs/String messages per second, sensor_msgs/Image 1920x1080 rgb8 messages per second
and MB/s, and the latency of std_msgs/Header messages sent 200 times a second (stamp to arrival
after decoding, wall clocks of one machine), for the zros subscriber, rosbridge JSON and
rosbridge CBOR, with the ratios to zros. The client's outbox in the gateway holds a million
messages and 100 MB, so what a slow decoder loses shows as messages received.

    python benchmarks/rosbridge.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
sys.path[:0] = [str(HERE.parent), str(HERE.parents[1])]

import gateway as stamped  # noqa: E402  (the stamped-header publisher and the zros receiver)
import transport as bench  # noqa: E402  (the publisher and the zros subscriber roles)

TOPIC = stamped.TOPIC
TYPES = {
    'string': 'std_msgs/msg/String',
    'image': 'sensor_msgs/msg/Image',
    'stamps': 'std_msgs/msg/Header',
}


# --- the client (a process of its own) ----------------------------------------------------------


def role_client(args: argparse.Namespace) -> None:
    """Subscribe through the gateway, decode and count ``count`` messages (or stop once nothing
    came for 20 s); print the count, the seconds from the first to the last, the bytes, and for
    stamped headers the latencies (ns)."""
    import cbor2
    from websockets.sync.client import connect

    with connect(args.url, max_size=None) as websocket:
        websocket.send(
            json.dumps(
                {
                    'op': 'subscribe',
                    'topic': TOPIC,
                    'type': TYPES[args.kind],
                    'compression': args.compression,
                }
            )
        )
        print('ready', flush=True)
        count, size, first, last, latencies = 0, 0, 0.0, 0.0, []
        while count < args.count:
            try:
                frame = websocket.recv(timeout=20 if count else 120)
            except TimeoutError:
                break
            message = cbor2.loads(frame) if isinstance(frame, bytes) else json.loads(frame)
            if message.get('op') != 'publish':
                continue
            last = time.monotonic()
            if not count:
                first = last
            count += 1
            size += len(frame)
            if args.kind == 'stamps':
                stamp = message['msg']['stamp']
                latencies.append(time.time_ns() - (stamp['sec'] * 10**9 + stamp['nanosec']))
    print(
        json.dumps({'count': count, 'seconds': last - first, 'bytes': size, 'latencies': latencies})
    )


# --- the gateway ---------------------------------------------------------------------------------


class Gateway:
    """``zros rosbridge`` in a process of its own."""

    def __init__(self, endpoint: str) -> None:
        zros = shutil.which('zros', path=str(Path(sys.executable).parent))
        assert zros is not None, 'the zros command is not installed beside this Python'
        self.process = subprocess.Popen(
            [zros, 'rosbridge', '--connect', endpoint, '--port', '0', '--client-queue', '1000000',
             '--client-buffer', '100MB', '--max-message-size', '100000000'],
            stdout=subprocess.PIPE,
            text=True,
        )  # fmt: skip
        assert self.process.stdout is not None
        line = self.process.stdout.readline()
        if not line.startswith('rosbridge: '):
            raise RuntimeError(f'zros rosbridge did not start: {line!r}')
        self.url = line.split()[1]

    def client(self, kind: str, compression: str, count: int) -> subprocess.Popen[str]:
        command = [sys.executable, str(HERE), '--role', 'client', '--url', self.url]
        command += ['--kind', kind, '--compression', compression, '--count', str(count)]
        process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)
        bench.wait_ready(process)
        return process

    def close(self) -> None:
        self.process.terminate()
        self.process.wait(30)


def through_gateway(kind: str, compression: str, count: int, endpoint: str) -> dict[str, Any]:
    gateway = Gateway(endpoint)
    try:
        client = gateway.client(kind, compression, count)
        if kind == 'stamps':
            publisher = stamped._spawn_here('stamps', endpoint, count)
        else:
            extra = ['--kind', kind, '--count', str(count)]
            publisher = bench.spawn_role('publish', 'zros', endpoint, extra, False)
        found = bench.read_result(client, 600)
        publisher.communicate(timeout=120)
    finally:
        gateway.close()
    found['rate'] = (found['count'] - 1) / max(found['seconds'], 1e-9)
    return found


# --- the driver ----------------------------------------------------------------------------------


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true')
    parser.add_argument('--repeats', type=int, default=0, help='runs per row (default 3, 1 quick)')
    parser.add_argument('--role', help=argparse.SUPPRESS)
    parser.add_argument('--url', help=argparse.SUPPRESS)
    parser.add_argument('--kind', help=argparse.SUPPRESS)
    parser.add_argument('--compression', help=argparse.SUPPRESS)
    parser.add_argument('--count', type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role == 'client':
        role_client(args)
        return

    from zros.transport import start_router

    router = start_router(shared_memory=False)
    endpoint = router.endpoint
    counts = {
        'string': 10_000 if args.quick else 50_000,
        'image': 20 if args.quick else 100,
        'stamps': 400 if args.quick else 2000,
    }
    repeats = args.repeats or (1 if args.quick else 3)
    print(
        'zros rosbridge benchmark: publisher, router, then zros rosbridge and a websockets '
        f'client decoding JSON or CBOR, or a zros subscriber; median of {repeats} runs'
    )
    rows: dict[str, dict[str, list[dict[str, Any]]]] = {}
    for _ in range(repeats):
        for kind in ('string', 'image'):
            count = counts[kind]
            found = bench.throughput('zros', kind, count, endpoint, False)
            rows.setdefault('zros', {}).setdefault(kind, []).append(
                {
                    'rate': found['rate'],
                    'count': found.get('received', count),
                    'size': found.get('size', 0),
                }
            )
            for compression in ('none', 'cbor'):
                found = through_gateway(kind, compression, count, endpoint)
                rows.setdefault(compression, {}).setdefault(kind, []).append(found)
    latency = {'zros': [float(x) for x in stamped.zros_latency(counts['stamps'], endpoint)]}
    for compression in ('none', 'cbor'):
        found = through_gateway('stamps', compression, counts['stamps'], endpoint)
        latency[compression] = [float(x) for x in found['latencies']]
    router.close()
    report({n: {k: median_run(v) for k, v in r.items()} for n, r in rows.items()}, latency)


def median_run(runs: list[dict[str, Any]]) -> dict[str, Any]:
    return sorted(runs, key=lambda run: run['rate'])[len(runs) // 2]


def report(rows: dict[str, dict[str, dict[str, Any]]], latency: dict[str, list[float]]) -> None:
    image_mb = 1920 * 1080 * 3 / 1e6
    z, j, c = rows['zros'], rows['none'], rows['cbor']
    print()
    print(f'{"":30} {"zros sub":>10} {"JSON":>10} {"CBOR":>10} {"JSON/zros":>10} {"CBOR/zros":>10}')
    for label, kind, scale in (
        ('String msgs/s', 'string', 1.0),
        ('Image 1080p msgs/s', 'image', 1.0),
        ('Image 1080p MB/s (pixels)', 'image', image_mb),
    ):
        ours, js, cb = (r[kind]['rate'] * scale for r in (z, j, c))
        print(
            f'{label:30} {ours:>10,.1f} {js:>10,.1f} {cb:>10,.1f} {js / ours:>10.2f} {cb / ours:>10.2f}'
        )
    medians = {name: statistics.median(found) / 1e3 for name, found in latency.items()}
    p99 = {name: sorted(found)[int(len(found) * 0.99)] / 1e3 for name, found in latency.items()}
    line = f'{medians["zros"]:>10,.0f} {medians["none"]:>10,.0f} {medians["cbor"]:>10,.0f}'
    print(f'{"Header latency median us":30} {line}')
    line = f'{p99["zros"]:>10,.0f} {p99["none"]:>10,.0f} {p99["cbor"]:>10,.0f}'
    print(f'{"Header latency p99 us":30} {line}')
    received = {name: {k: v['count'] for k, v in row.items()} for name, row in rows.items()}
    print(
        f'\n  messages received: {received}; latency samples: { {k: len(v) for k, v in latency.items()} }'
    )


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()
