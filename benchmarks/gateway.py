"""Gateway speed: messages through ``zros foxglove`` to a Foxglove client, against zros's own
subscriber, in the same run.

A publisher process (the one of ``benchmarks/transport.py``) sends as fast as the transport
takes; the messages go through a router (started here) to

  * a zros subscriber process (callbacks, as ``transport.py`` measures it), or
  * the ``zros foxglove`` command in a process of its own, to the ``@foxglove/ws-protocol``
    client run by node (``tests/gateway/node``; needs node and npm), which counts them, or to
    a lean client that counts message frames with node's ``ws`` and parses nothing else of
    them (``tests/gateway/node/counter.js``): the library's client parses each message and
    copies it out of node's buffer, and on two cores its CPU is taken from the server's.

Rows: std_msgs/String messages per second, sensor_msgs/Image 1920x1080 rgb8 in MB/s, and the
latency of std_msgs/Header messages sent 200 times a second (stamp to arrival, wall clocks of
one machine), each through the gateway and to the zros subscriber, with their ratios. The
gateway's per-client outbox is made large enough that nothing is dropped.

Two more rows per kind bound what a gateway on foxglove-sdk can do here: a process that logs
the same message's CDR bytes on an SDK channel as fast as it takes them, with no Zenoh, no
router and no copy of its own, to the same node client; and raw zenoh-python logging each
sample's bytes into the SDK from its callback (the gateway's work without zros).

One more path is the gateway with its client on the SDK's own server, past the front that
checks origins, answers both subprotocols and bounds each client in bytes: the rate it gains
over the gateway is what the front costs, measured in the same run.

All six paths are up at once, each on a topic of its own, and they take turns (10 each, after
one to warm up; the median turn's rate counts): this VM's speed drifts by a third within
minutes, more than the differences measured, and turns make the drift fall on every path alike.

On two cores every process competes for the same CPU, so the rates follow the CPU each path
spends per message, which the second table gives per process. Its last rows give each
receiver's busiest thread (ticks of /proc, 10 ms): where every thread has a core of its own,
the busiest thread of a path's slowest stage bounds its rate.

    python benchmarks/gateway.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
sys.path[:0] = [str(HERE.parent), str(HERE.parents[1])]

import transport as bench  # noqa: E402  (the publisher and the zros subscriber roles)
from gateway_paths import (  # noqa: E402
    ClientPath,
    ZrosPath,
    gateway_command,
    start_server,
    topic,
)
from transport_roles import total  # noqa: E402

from tests.gateway.foxglove.client import SDK_PROTOCOL as SDK  # noqa: E402
from tests.gateway.foxglove.client import FoxgloveClient  # noqa: E402
from tests.gateway.node_process import install  # noqa: E402

LATENCY_HZ = 200.0
TOPIC = '/bench/data'


# --- roles (run in their own processes) -------------------------------------------------------


def role_stamps(args: argparse.Namespace) -> None:
    """Publish ``count`` std_msgs/Header stamped with the wall clock, LATENCY_HZ a second."""
    node = bench.zros_node('bench_stamps', args.endpoint, False)
    publisher = node.create_publisher('std_msgs/msg/Header', TOPIC, qos=100)
    publisher.wait_for_subscribers(30)
    time.sleep(0.5)  # the receiver finishes subscribing
    message = publisher.msg_type()
    period = 1.0 / LATENCY_HZ
    due = time.monotonic()
    for _ in range(args.count):
        message.stamp.sec, message.stamp.nanosec = divmod(time.time_ns(), 10**9)
        publisher.write(message)
        due += period
        time.sleep(max(0.0, due - time.monotonic()))
    time.sleep(1)
    node.transport.close()


def _watched_channel(kind: str, timeout: float, name: str = TOPIC) -> tuple[Any, Any]:
    """An SDK server and a channel on ``name`` (cdr) of ``kind``'s type, its URL printed as
    ``zros foxglove`` prints it; returns once a client subscribed (or after ``timeout`` s)."""
    import foxglove
    from transport_roles import type_of

    from zros.cdr import default_registry
    from zros.gateway.foxglove.sdk import ros2msg_schema

    schema = ros2msg_schema(default_registry(), type_of(kind))
    server = foxglove.start_server(host='127.0.0.1', port=0, message_backlog_size=1_000_000)
    channel = foxglove.Channel(name, schema=schema, message_encoding='cdr')
    print(f'Foxglove: ws://127.0.0.1:{server.port}', flush=True)
    deadline = time.monotonic() + timeout
    while not channel.has_sinks() and time.monotonic() < deadline:
        time.sleep(0.01)
    return server, channel


def role_sdk(args: argparse.Namespace) -> None:
    """foxglove-sdk alone: once a client subscribes, each line ``N`` read from stdin logs one
    message's CDR bytes N times (with a stamp, as the gateway logs them); ends at EOF."""
    from transport_roles import payload

    from zros.cdr import encode

    data = encode(payload(args.kind))
    _server, channel = _watched_channel(args.kind, args.timeout, topic(args.tag))
    log = channel.base.log
    for line in sys.stdin:
        for _ in range(int(line)):
            log(data, time.time_ns())


def role_zenoh_sdk(args: argparse.Namespace) -> None:
    """Raw zenoh-python into foxglove-sdk: each sample's bytes logged on an SDK channel from
    Zenoh's callback (what the gateway does, without zros)."""
    from transport_roles import raw_session

    session = raw_session(args.endpoint, False)
    name = topic(args.tag)
    _server, channel = _watched_channel(args.kind, args.timeout, name)
    log = channel.base.log
    subscriber = session.declare_subscriber(  # once watched, as the gateway taps a topic
        name.lstrip('/'), lambda sample: log(sample.payload.to_bytes(), time.time_ns())
    )
    time.sleep(args.timeout)  # the driver ends this process
    subscriber.undeclare()
    session.close()


def role_gateway_direct(args: argparse.Namespace) -> None:
    """``zros foxglove``'s gateway with its client on the SDK's server itself, past the front
    (which checks origins, names both subprotocols and bounds each client in bytes): what the
    front costs, measured beside the gateway. Ends when the driver kills it."""
    from urllib.parse import parse_qs, urlparse

    from zros.gateway.foxglove.sdk import ServerOptions
    from zros.gateway.foxglove.server import FoxgloveGateway

    found: list[str] = []

    class Direct(ServerOptions):
        def start(self, **settings: Any) -> Any:
            server, front = super().start(**settings)
            found.append(parse_qs(urlparse(server.app_url()).query)['ds.url'][0])
            return server, front

    node = bench.zros_node('bench_gateway_direct', args.endpoint, False)
    options = Direct(port=0, message_backlog=1_000_000, client_buffer=16 * 1024**3)
    gateway = FoxgloveGateway(node, options, sim_time=False)
    print(f'Foxglove: {found[0]}', flush=True)
    try:
        threading.Event().wait()
    finally:
        gateway.close()


def role_latency(args: argparse.Namespace) -> None:
    """Receive stamped headers with a zros subscriber; print the latencies (ns)."""
    node = bench.zros_node('bench_latency', args.endpoint, False)
    latencies: list[int] = []

    def on_message(message: Any) -> None:
        latencies.append(time.time_ns() - (message.stamp.sec * 10**9 + message.stamp.nanosec))

    node.create_subscription('std_msgs/msg/Header', TOPIC, on_message, qos=100)
    print('ready', flush=True)
    deadline = time.monotonic() + args.timeout
    while len(latencies) < args.count and time.monotonic() < deadline:
        node.spin_once(0.5)
    node.transport.close()
    print(json.dumps({'latencies': latencies}))


# --- through the gateway ------------------------------------------------------------------------


class Gateway:
    """``zros foxglove`` in a process of its own, and a node client subscribed to TOPIC."""

    def __init__(self, endpoint: str) -> None:
        self.process, url = start_server(gateway_command(endpoint))
        self.client = FoxgloveClient(url)

    def subscribe(self, latency: bool = False) -> int:
        """Subscribe to TOPIC once a publisher made it appear, and return once its first
        message came (a channel left over from the previous run's publisher may vanish:
        then the new one is subscribed). Messages are counted from the first, not shown."""
        client = self.client
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            channel = client.channel(TOPIC, 60)['id']
            subscription = client.subscribe(TOPIC, 60, quiet=True, latency=latency)
            while time.monotonic() < deadline:
                if any(channel in e['channelIds'] for e in client.of('unadvertise')):
                    break
                if client.stats()[str(subscription)]['count'] > 0:
                    return subscription
                time.sleep(0.05)
        raise RuntimeError(f'no message on {TOPIC} through the gateway')

    def counted(self, subscription: int, count: int, timeout: float) -> dict[str, Any]:
        """The client's counts once ``count`` arrived, or once nothing came for ``timeout``."""
        progress, last = -1, time.monotonic()
        while True:
            found = dict(self.client.stats()[str(subscription)])
            if found['count'] >= count or time.monotonic() - last > timeout:
                return found
            if found['count'] != progress:
                progress, last = found['count'], time.monotonic()
            time.sleep(0.2)

    def close(self) -> None:
        self.client.close()
        self.process.terminate()
        self.process.wait(30)


#: the paths a message takes, in the order they take their turns
PATHS = ('zros', 'gateway', 'gateway_direct', 'gateway_lean', 'sdk', 'zenoh_sdk')
#: turns each path takes in one run (after one to warm up)
TURNS = 10


def interleaved(kind: str, count: int, endpoint: str) -> dict[str, dict[str, Any]]:
    """``count`` messages of ``kind`` along each path, every path up at once (topics of their
    own) and taking turns of ``count //`` :data:`TURNS`: the zros subscriber; ``zros foxglove``
    to the node client, and to a lean one that only counts frames; foxglove-sdk alone (sending
    itself, no Zenoh) to the node client; raw zenoh-python logging into the SDK, to the node
    client. Each path's median turn rate, and its CPU and messages added up."""
    turn = max(count // TURNS, 2)
    here = [sys.executable, str(HERE), '--kind', kind, '--endpoint', endpoint]
    gateway = gateway_command(endpoint)
    paths: dict[str, Any] = {}
    try:
        paths['zros'] = ZrosPath(kind, endpoint, '0', turn)
        paths['gateway'] = ClientPath(gateway, kind, endpoint, '1', publish=True)
        paths['gateway_lean'] = ClientPath(gateway, kind, endpoint, '4', publish=True, lean=True)
        command = [*here, '--role', 'gateway_direct', '--tag', '5']
        paths['gateway_direct'] = ClientPath(
            command, kind, endpoint, '5', publish=True, protocol=SDK
        )
        command = [*here, '--role', 'sdk', '--tag', '2', '--timeout', '300']
        # the SDK's own server accepts its subprotocol only (zros foxglove's front both)
        paths['sdk'] = ClientPath(command, kind, endpoint, '2', publish=False, protocol=SDK)
        command = [*here, '--role', 'zenoh_sdk', '--tag', '3', '--timeout', '3600']
        paths['zenoh_sdk'] = ClientPath(command, kind, endpoint, '3', publish=True, protocol=SDK)
        turns: dict[str, list[dict[str, Any]]] = {name: [] for name in PATHS}
        for _ in range(TURNS + 1):
            for name in PATHS:
                turns[name].append(paths[name].turn(turn))
    finally:
        for path in paths.values():
            path.close()
    return {name: total(found[1:]) for name, found in turns.items()}  # the first warms up


def _spawn_here(role: str, endpoint: str, count: int) -> subprocess.Popen[str]:
    command = [sys.executable, str(HERE), '--role', role, '--endpoint', endpoint]
    return subprocess.Popen([*command, '--count', str(count)], stdout=subprocess.PIPE, text=True)


def gateway_latency(count: int, endpoint: str) -> list[float]:
    gateway = Gateway(endpoint)
    try:
        publisher = _spawn_here('stamps', endpoint, count)  # waits for a subscriber
        subscription = gateway.subscribe(latency=True)
        found = gateway.counted(subscription, count, 10)
        publisher.communicate(timeout=120)
    finally:
        gateway.close()
    return [float(x) for x in found['latencies']]


def zros_latency(count: int, endpoint: str) -> list[float]:
    receiver = _spawn_here('latency', endpoint, count)
    bench.wait_ready(receiver)
    publisher = _spawn_here('stamps', endpoint, count)
    result = bench.read_result(receiver, 120)
    publisher.communicate(timeout=120)
    return [float(x) for x in result['latencies']]


# --- the driver ----------------------------------------------------------------------------------


def _median_run(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """The run with the median rate."""
    return sorted(runs, key=lambda run: run['rate'])[len(runs) // 2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true')
    parser.add_argument('--repeats', type=int, default=0, help='runs per row (default 3, 1 quick)')
    parser.add_argument('--role', help=argparse.SUPPRESS)
    parser.add_argument('--endpoint', help=argparse.SUPPRESS)
    parser.add_argument('--count', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--kind', default='image', help=argparse.SUPPRESS)
    parser.add_argument('--timeout', type=float, default=120, help=argparse.SUPPRESS)
    parser.add_argument('--tag', default='', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.role:
        roles = {'stamps': role_stamps, 'latency': role_latency, 'sdk': role_sdk}
        roles['zenoh_sdk'] = role_zenoh_sdk
        roles['gateway_direct'] = role_gateway_direct
        roles[args.role](args)
        return
    reason = install()
    if reason is not None:
        sys.exit(f'the gateway benchmark needs the node client: {reason}')

    from importlib import metadata

    from zros.transport import start_router

    router = start_router(shared_memory=False)
    endpoint = router.endpoint
    strings = 20_000 if args.quick else 100_000
    images = 30 if args.quick else 150
    stamps = 400 if args.quick else 2000
    repeats = args.repeats or (1 if args.quick else 3)
    print(
        f'zros gateway benchmark: publisher, router, then zros foxglove and a node '
        f'@foxglove/ws-protocol client, or a zros subscriber; foxglove-sdk '
        f'{metadata.version("foxglove-sdk")}, median of {repeats} alternating runs'
    )
    runs: dict[str, dict[str, list[dict[str, Any]]]] = {
        name: {'string': [], 'image': []} for name in PATHS
    }
    for _ in range(repeats):
        for kind, count in (('string', strings), ('image', images)):
            for name, found in interleaved(kind, count, endpoint).items():
                runs[name][kind].append(found)
    latency = {'zros': zros_latency(stamps, endpoint), 'gateway': gateway_latency(stamps, endpoint)}
    router.close()
    report(
        {name: {k: _median_run(v) for k, v in rows.items()} for name, rows in runs.items()}, latency
    )


def report(rows: dict[str, dict[str, dict[str, Any]]], latency: dict[str, list[float]]) -> None:
    def mbs(row: dict[str, Any]) -> float:
        return float(row['rate'] * row['size'] / 1e6)

    z, g = rows['zros'], rows['gateway']
    print()
    print(f'{"":36} {"zros sub":>10} {"gateway":>10} {"gw/zros":>8}')
    lines = [
        ('String msgs/s', z['string']['rate'], g['string']['rate']),
        ('String MB/s', mbs(z['string']), mbs(g['string'])),
        ('Image 1080p msgs/s', z['image']['rate'], g['image']['rate']),
        ('Image 1080p MB/s', mbs(z['image']), mbs(g['image'])),
    ]
    for label, ours, theirs in lines:
        print(f'{label:36} {ours:>10,.1f} {theirs:>10,.1f} {theirs / ours:>8.2f}')

    def amount(row: dict[str, Any], kind: str) -> float:  # what the rows above compare
        return float(row['rate']) if kind == 'string' else mbs(row)

    labels = [
        ('gateway_direct', 'gateway past its front'),
        ('gateway_lean', 'gateway, lean client'),
    ]
    labels.append(('sdk', 'foxglove-sdk alone'))
    for name, label in [*labels, ('zenoh_sdk', 'raw zenoh into the SDK')]:
        for kind, unit in (('string', 'String msgs/s'), ('image', 'Image MB/s')):
            other = amount(rows[name][kind], kind)
            print(
                f'{unit + ", " + label:36} {"":>10} {other:>10,.1f} '
                f'{other / amount(z[kind], kind):>8.2f}'
                f'   (gateway / it: {amount(g[kind], kind) / other:.2f})'
            )
    print()
    print(f'{"CPU per message, us":36} {"String":>10} {"Image":>10}')
    cpu_rows = [
        ('to zros: publisher process', 'zros', 'cpu_publisher'),
        ('  router (in this process)', 'zros', 'cpu_router'),
        ('  zros subscriber process', 'zros', 'cpu'),
        ('to the gateway: publisher process', 'gateway', 'cpu_publisher'),
        ('  router (in this process)', 'gateway', 'cpu_router'),
        ('  zros foxglove process', 'gateway', 'cpu'),
        ('  its front process', 'gateway', 'cpu_front'),
        ('  its node client process', 'gateway', 'cpu_client'),
        ('  a lean client process instead', 'gateway_lean', 'cpu_client'),
        ('past the front: zros foxglove process', 'gateway_direct', 'cpu'),
        ('  its node client process', 'gateway_direct', 'cpu_client'),
        ('foxglove-sdk alone, its process', 'sdk', 'cpu'),
        ('  its node client process', 'sdk', 'cpu_client'),
        ('raw zenoh into the SDK, its process', 'zenoh_sdk', 'cpu'),
        ('  its node client process', 'zenoh_sdk', 'cpu_client'),
        ('busiest thread: zros subscriber', 'zros', 'cpu_thread'),
        ('  zros foxglove', 'gateway', 'cpu_thread'),
        ('  its front', 'gateway', 'cpu_front_thread'),
        ('  its node client', 'gateway', 'cpu_client_thread'),
        ('  a lean client instead', 'gateway_lean', 'cpu_client_thread'),
        ('  foxglove-sdk alone', 'sdk', 'cpu_thread'),
    ]
    for label, name, key in cpu_rows:
        cells = [
            f'{1e6 * row[key] / row["received"]:>10,.1f}' if row and key in row else f'{"":>10}'
            for row in (rows[name].get('string'), rows[name].get('image'))
        ]
        print(f'{label:36} {" ".join(cells)}')
    medians = {name: statistics.median(found) / 1e3 for name, found in latency.items()}
    p99 = {name: sorted(found)[int(len(found) * 0.99)] / 1e3 for name, found in latency.items()}
    print(
        f'{"Header latency median us (200 Hz)":36} {medians["zros"]:>10,.0f} {medians["gateway"]:>10,.0f}'
    )
    print(f'{"Header latency p99 us":36} {p99["zros"]:>10,.0f} {p99["gateway"]:>10,.0f}')
    print()
    added = medians['gateway'] - medians['zros']
    goals = []
    for name, client in (('gateway', 'the node client'), ('gateway_lean', 'a lean client')):
        found = rows[name]
        goals += [
            (
                f'String rate through the gateway >= 80 % of zros ({client})',
                found['string']['rate'] >= 0.8 * z['string']['rate'],
            ),
            (
                f'Image MB/s through the gateway >= 90 % of zros ({client})',
                mbs(found['image']) >= 0.9 * mbs(z['image']),
            ),
        ]
    for kind, label in (('string', 'String'), ('image', 'Image')):
        cost = (amount(rows['gateway_direct'][kind], kind) - amount(g[kind], kind)) / amount(
            z[kind], kind
        )
        goals.append(
            (f'the front costs the {label} ratio <= 0.03 (it costs {cost:.2f})', cost <= 0.03)
        )
    for text, met in goals:
        print(f'  {"met   " if met else "MISSED"}  {text}')
    print(f'  latency the gateway adds (median): {added:,.0f} us')
    received = {name: {k: v['received'] for k, v in row.items()} for name, row in rows.items()}
    print(
        f'  messages received: {received}; latency samples: { {k: len(v) for k, v in latency.items()} }'
    )


if __name__ == '__main__':
    from readme import recording

    threading.current_thread().name = 'bench'
    with recording(__file__):
        main()
