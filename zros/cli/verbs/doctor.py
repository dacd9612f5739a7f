"""``zros doctor``: can this machine reach the robot, and what is there?

Checks, each printed as ``ok``, ``warn`` or ``FAIL`` with what to do: the Zenoh session (the
endpoint, TLS, the router's Zenoh version against this eclipse-zenoh), the bridges (version,
namespace, type-hash support), the wire schemes present, the graph's size, and the clocks
(``/clock`` for sim time; ``/rosout`` stamps against this machine's clock). Exit code 1 when a
check failed.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import threading
import time
from typing import TYPE_CHECKING

from zros.cli.shared import add_connection_options, counted, open_node, out

if TYPE_CHECKING:
    import zenoh

    from zros.graph import Graph
    from zros.node import Node

SKEW_WARNING = 0.5  #: seconds between clocks that make header stamps misleading


class Report:
    """Lines of a diagnosis; remembers whether anything failed."""

    def __init__(self) -> None:
        self.failed = False

    def ok(self, text: str) -> None:
        out(f'  ok    {text}')

    def warn(self, text: str) -> None:
        out(f'  warn  {text}')

    def fail(self, text: str) -> None:
        self.failed = True
        out(f'  FAIL  {text}')


def _version(text: str) -> tuple[int, ...]:
    digits = text.lstrip('v').split('-')[0].split('.')
    return tuple(int(d) for d in digits if d.isdigit())


def _routers(session: zenoh.Session, report: Report, local: str) -> None:
    found = 0
    for reply in session.get('@/*/router', timeout=2.0):
        if reply.ok is None:
            continue
        try:
            info = json.loads(reply.ok.payload.to_string())
        except ValueError:
            continue
        found += 1
        version = str(info.get('version', '?')).split(' ')[0]
        text = f'router {info.get("zid", "?")} runs Zenoh {version}'
        theirs, ours = _version(version), _version(local)
        if theirs[:1] != ours[:1]:
            report.fail(f'{text}: Zenoh {theirs[:1]} and {ours[:1]} do not interoperate')
        elif theirs[:2] != ours[:2]:
            report.warn(f'{text}; this machine has {local} (1.x releases interoperate)')
        else:
            report.ok(text)
    if not found:
        report.warn('no Zenoh router answered (peer mode, or a router without admin space)')


def _bridges(graph: Graph, report: Report) -> None:
    bridges = graph.bridges()
    if not bridges:
        report.warn(
            'no zenoh-bridge-ros2dds answered: DDS robots are reachable only through one '
            '(rmw_zenoh robots need none)'
        )
    for bridge in bridges:
        version = bridge.version_tuple
        text = (
            f'bridge {bridge.zid} {bridge.version or "(version unknown)"}, '
            f'namespace {bridge.namespace or "/"}, ROS node {bridge.node_name}'
        )
        if version is None:
            report.warn(f'{text}: its admin space did not answer')
        elif version < (1, 0):
            report.fail(f'{text}: zros needs a bridge of 1.0 or later (Zenoh 1.x)')
        elif version < (1, 0, 4):
            report.warn(f'{text}: before 1.0.4 bridges ignore type hashes')
        else:
            report.ok(text)


def _clocks(node: Node, graph: Graph, listen: float, report: Report) -> None:
    topics = graph.topics(node.scheme.namespace)
    if '/clock' in topics:
        report.warn('/clock is published: the robot runs on simulated time (use_sim_time)')
    if '/rosout' not in topics or listen <= 0:
        report.ok('clock skew not measured (no /rosout to compare stamps with)')
        return
    from zros.cdr import CdrError, decode
    from zros.pubsub.taps import RawTap
    from zros.qos import QoS, Reliability

    log_type = 'rcl_interfaces/msg/Log'
    log_class = node.registry.get_class(log_type)
    offsets: list[float] = []
    enough = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        try:
            stamp = decode(log_class, sample.payload.to_bytes()).stamp
        except CdrError:  # not a Log: nothing to compare
            return
        offsets.append(time.time() - (stamp.sec + stamp.nanosec * 1e-9))
        if len(offsets) >= 20:
            enough.set()

    # the node's wire gives the key (and, under rmw_zenoh, admits only attached samples)
    qos = QoS(1000, Reliability.BEST_EFFORT)
    tap = RawTap(node, '/rosout', log_type, qos=qos, key=None, callback=on_sample)
    enough.wait(listen)
    tap.close()
    if not offsets:
        report.ok(f'clock skew not measured (nothing on /rosout within {listen:g} s)')
        return
    skew = statistics.median(offsets)
    text = f'this clock is {skew:+.3f} s from /rosout stamps (latency included)'
    if abs(skew) > SKEW_WARNING:
        report.warn(f'{text}: header stamps will look shifted; synchronise the clocks (NTP)')
    else:
        report.ok(text)


def run(args: argparse.Namespace) -> int:
    from importlib.metadata import version

    import zros
    from zros.errors import SettingError, ZrosError, command_line_text
    from zros.graph import Graph
    from zros.transport import Transport
    from zros.wire import session_config

    zenoh_version = version('eclipse-zenoh')
    report = Report()
    out(f'zros {zros.__version__}, Python {sys.version.split()[0]}, eclipse-zenoh {zenoh_version}')
    out('session')
    try:
        config = session_config(args.connect, mode=args.mode, wire=args.wire)
        transport = Transport(config)
    except SettingError:
        raise  # a usage error: one line, exit 2
    except ZrosError as exc:
        report.fail(command_line_text(exc))
        return 1
    try:
        report.ok(f'connected to {config.describe()} as {transport.zid}')
        _routers(transport.session, report, zenoh_version)
        graph = Graph(transport)
        graph.refresh(args.wait)
        out('ROS graph')
        _bridges(graph, report)
        wires = graph.wires()
        report.ok(f'wire schemes present: {", ".join(wires) or "none yet"}')
        report.ok(
            ', '.join(
                counted(len(items), noun)
                for items, noun in (
                    (graph.nodes(), 'node'),
                    (graph.topics(), 'topic'),
                    (graph.services(), 'service'),
                    (graph.actions(), 'action'),
                )
            )
        )
        out('clocks')
        with open_node(args, transport=transport) as node:  # after counting: not counted
            _clocks(node, graph, args.listen, report)
        graph.close()
    finally:
        transport.close()
    out('problems found' if report.failed else 'no problems found')
    return 1 if report.failed else 0


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    parser = commands.add_parser('doctor', help=help_line, description=__doc__)
    parser.add_argument('--wait', type=float, default=2.0, help='seconds to discover the graph')
    parser.add_argument('--listen', type=float, default=2.0,
                        help='seconds to listen to /rosout for clock skew (0: skip)')  # fmt: skip
    add_connection_options(parser)
    parser.set_defaults(run=run)
