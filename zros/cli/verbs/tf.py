"""``zros tf echo`` (tf2_echo) and ``zros tf frames`` (view_frames), live or from a recording,
and ``zros tf monitor`` (tf2_monitor), live."""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import TYPE_CHECKING

from zros.cli.shared import CommandError, add_connection_options, add_verbs, open_node, out

if TYPE_CHECKING:
    from zros.cdr import Message
    from zros.plot.graph_data import GraphModel, Measure
    from zros.tf import Buffer, EdgeInfo

_NS = 1_000_000_000


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'tf', help_line)

    echo_parser = verbs.add_parser(
        'echo',
        help='print the transform between two frames, as tf2_echo',
        description='Print the transform taking data in SOURCE to TARGET (where SOURCE is in '
        'TARGET): translation, rotation as a quaternion and as roll, pitch, yaw in radians and '
        'degrees, and the 4x4 matrix, as tf2_echo prints them. Live: the latest transform, '
        'RATE times a second, until Ctrl-C. From a recording (--bag): at RATE instants per '
        'second of recording time over the span the chain covers.',
        epilog='examples: zros tf echo map base_link; zros tf echo odom base_link --rate 10 '
        '--count 5; zros tf echo map base_footprint --bag run1/ --rate 0.5',
    )
    echo_parser.add_argument(
        'target', metavar='TARGET', help='the frame to express the transform in'
    )
    echo_parser.add_argument('source', metavar='SOURCE', help='the frame whose pose is printed')
    echo_parser.add_argument('--rate', type=float, default=1.0, metavar='HZ', help='default 1')
    echo_parser.add_argument(
        '--bag', metavar='PATH', help='read a recording instead of the network'
    )
    echo_parser.add_argument('--count', type=int, metavar='N', help='stop after N transforms')
    echo_parser.add_argument(
        '--precision', type=int, default=3, metavar='DIGITS', help='decimals (default 3)'
    )
    echo_parser.set_defaults(run=echo)
    add_connection_options(echo_parser)

    frames_parser = verbs.add_parser(
        'frames',
        help='the tree of frames: parents, publishers, rates (view_frames)',
        description='Print the tree of frames as tf2 does (each frame: its parent, the '
        'publisher of its transforms, their rate, the most recent and the oldest stamp, the '
        'buffer length), live after listening for --wait seconds, or for a whole recording '
        '(--bag). With -o, draw it too (.png, .svg, .pdf; .dot for Graphviz).',
        epilog='examples: zros tf frames; zros tf frames --bag run1/ -o frames.pdf; '
        'zros tf frames --wait 5 -o frames.svg',
    )
    frames_parser.add_argument(
        '--bag', metavar='PATH', help='read a recording instead of the network'
    )
    frames_parser.add_argument('-o', '--output', metavar='FILE', help='write the picture to FILE')
    frames_parser.add_argument(
        '--wait',
        type=float,
        default=2.0,
        metavar='S',
        help='live: seconds to listen before printing (default 2)',
    )
    frames_parser.set_defaults(run=frames)
    add_connection_options(frames_parser)

    monitor_parser = verbs.add_parser(
        'monitor',
        help='how late transforms arrive, per frame and broadcaster (tf2_monitor)',
        description='Listen to /tf and /tf_static and print, every PERIOD seconds, what '
        'tf2_monitor prints: for each frame, who publishes it and how late its transforms '
        "arrive (arrival on this machine's clock less the stamp: the clocks must agree, as "
        'for tf2_monitor), and for each broadcaster its rate and delay. With TARGET and '
        'SOURCE, only the frames of that chain, and the delay of its latest transform '
        '(sampled twice a second).',
        epilog='examples: zros tf monitor; zros tf monitor map base_link --period 5 --count 1',
    )
    monitor_parser.add_argument('frames', metavar='TARGET SOURCE', nargs='*', help='a chain')
    monitor_parser.add_argument(
        '--period', type=float, default=10.0, metavar='S', help='seconds between reports '
        '(default 10)'
    )  # fmt: skip
    monitor_parser.add_argument('--count', type=int, metavar='N', help='stop after N reports')
    monitor_parser.set_defaults(run=monitor)
    add_connection_options(monitor_parser)


# --- echo --------------------------------------------------------------------------------------


def format_transform(transform: Message, digits: int = 3) -> str:
    """A transform as tf2_echo prints it."""
    from zros.tf.quaternions import euler_from_quaternion, rotation_matrix

    t = transform.transform.translation
    q = transform.transform.rotation
    stamp = transform.header.stamp

    def row(values: tuple[float, ...] | list[float]) -> str:
        return '[' + ', '.join(f'{v:.{digits}f}' for v in values) + ']'

    rpy = euler_from_quaternion((q.x, q.y, q.z, q.w))
    matrix = rotation_matrix((q.x, q.y, q.z, q.w))
    # a chain of static transforms has no time: tf2_echo prints 'At time 0.0' (sec.nanosec)
    at = f'{stamp.sec}.{stamp.nanosec:09d}' if stamp.sec or stamp.nanosec else '0.0'
    lines = [
        f'At time {at}',
        f'- Translation: {row((t.x, t.y, t.z))}',
        f'- Rotation: in Quaternion (xyzw) {row((q.x, q.y, q.z, q.w))}',
        f'- Rotation: in RPY (radian) {row(rpy)}',
        f'- Rotation: in RPY (degree) {row([math.degrees(a) for a in rpy])}',
        '- Matrix:',
    ]
    width = digits + 4
    translation = (t.x, t.y, t.z)
    for i in range(3):
        cells = [*matrix[i].tolist(), translation[i]]
        lines.append(' ' + ' '.join(f'{v:{width}.{digits}f}' for v in cells))
    lines.append(' ' + ' '.join(f'{v:{width}.{digits}f}' for v in (0.0, 0.0, 0.0, 1.0)))
    return '\n'.join(lines)


def echo(args: argparse.Namespace) -> int:
    if args.rate <= 0:
        raise CommandError('--rate must be above 0')
    if args.bag:
        return _echo_bag(args)
    from zros.tf import Buffer, TransformException, TransformListener

    printed = 0
    with open_node(args) as node:
        buffer = Buffer()
        listener = TransformListener(buffer, node)
        period = 1.0 / args.rate
        due = time.monotonic() + min(period, 1.0)  # give latched frames a moment first
        try:
            while args.count is None or printed < args.count:
                time.sleep(max(0.0, due - time.monotonic()))
                due += period
                try:
                    transform = buffer.lookup_transform(args.target, args.source, 0)
                except TransformException as exc:
                    print(f'Waiting for transform {args.target} -> {args.source}: {exc}',
                          file=sys.stderr)  # fmt: skip
                    continue
                out(format_transform(transform, args.precision))
                printed += 1
        except KeyboardInterrupt:
            pass
        finally:
            listener.unregister()
    return 0


def _echo_bag(args: argparse.Namespace) -> int:
    import numpy as np

    from zros.tf import Buffer
    from zros.tf.messages import transform_message

    buffer = Buffer.from_bag(args.bag)
    changes = buffer.stamps(args.target, args.source)
    if len(changes):
        stamps = np.arange(changes[0], changes[-1] + 1, round(_NS / args.rate), dtype=np.int64)
    else:  # a static chain: one answer holds at every time
        stamps = np.zeros(1, dtype=np.int64)
    if args.count is not None:
        stamps = stamps[: args.count]
    translations, rotations = buffer.lookup_transforms(args.target, args.source, stamps)
    for stamp, t, q in zip(stamps.tolist(), translations.tolist(), rotations.tolist(), strict=True):
        pose = (*t, *q)
        out(
            format_transform(
                transform_message(args.target, args.source, stamp, pose), args.precision
            )
        )
    return 0


# --- frames ------------------------------------------------------------------------------------


def frames_model(edges: list[EdgeInfo]) -> GraphModel:
    """The tree as a graph picture's model: frames as ellipses, each edge through a box that
    says who publishes it, how often, and what the buffer holds."""
    from zros.plot.graph_data import GraphModel

    model = GraphModel()
    for edge in edges:
        model.add_node(edge.parent)
        model.add_node(edge.frame)
        label = '\n'.join(_edge_lines(edge))
        model.edges.add((model.add_node(edge.parent), model.add_topic(label)))
        model.edges.add((model.add_topic(label), model.add_node(edge.frame)))
    return model


def _edge_lines(edge: EdgeInfo) -> list[str]:
    if edge.static:
        return [f'{edge.parent} -> {edge.frame}', f'Broadcaster: {edge.authority}', 'static']
    return [
        f'{edge.parent} -> {edge.frame}',
        f'Broadcaster: {edge.authority}',
        f'Average rate: {edge.rate:.3f}',
        f'Most recent transform: {edge.newest / _NS:.3f}',
        f'Buffer length: {edge.buffer_length:.3f} s ({edge.length} transforms)',
    ]


def frames(args: argparse.Namespace) -> int:
    from zros.tf import Buffer

    if args.bag:
        buffer = Buffer.from_bag(args.bag)
        return _report_frames(args, buffer)
    from zros.runtime.signal import sleep
    from zros.tf import TransformListener

    with open_node(args) as node:
        buffer = Buffer()
        listener = TransformListener(buffer, node)
        try:
            sleep(args.wait)
        finally:
            listener.unregister()
        node.graph.refresh()  # the publishers are named from the graph: see all of it
        return _report_frames(args, buffer)


def _report_frames(args: argparse.Namespace, buffer: Buffer) -> int:
    edges = buffer.edges()
    if not edges:
        raise CommandError(
            'no transforms' + (f' in {args.bag}' if args.bag else f' within {args.wait:g} s')
        )
    out(buffer.all_frames_as_yaml().rstrip('\n'))
    if args.output:
        from zros.plot.graph_layout import layout_graph
        from zros.plot.graph_picture import FONT_SIZE, draw_graph, save_figure

        model = frames_model(edges)
        if args.output.lower().endswith(('.dot', '.gv')):
            from pathlib import Path

            from zros.plot.graph_picture import to_dot

            Path(args.output).write_text(to_dot(model))
        else:
            layout = layout_graph(model, _multiline_measure(), FONT_SIZE)
            save_figure(draw_graph(layout, model), args.output)
        out(f'wrote {args.output}')
    return 0


def _multiline_measure() -> Measure:
    from zros.plot.graph_picture import FONT_SIZE, font_measure

    one_line = font_measure(FONT_SIZE)

    def measure(text: str) -> tuple[float, float]:
        sizes = [one_line(line) for line in text.split('\n')]
        return max(w for w, _ in sizes), sum(h for _, h in sizes) * 1.25

    return measure


# --- monitor -----------------------------------------------------------------------------------


def monitor(args: argparse.Namespace) -> int:
    if len(args.frames) not in (0, 2):
        raise CommandError('give two frames (TARGET SOURCE) for a chain, or none for all frames')
    if args.period <= 0:
        raise CommandError('--period must be above 0')
    from zros.tf import Buffer, TransformException, TransformListener
    from zros.tf.monitor import DelayMonitor

    delays = DelayMonitor()
    reports = 0
    with open_node(args) as node:
        buffer = Buffer()
        listener = TransformListener(buffer, node, on_message=delays.record)
        chain: list[str] | None = None
        told = False
        sample = min(0.5, args.period)
        due = time.monotonic() + args.period
        try:
            while args.count is None or reports < args.count:
                time.sleep(max(0.0, min(sample, due - time.monotonic())))
                if args.frames:
                    target, source = args.frames
                    try:
                        found = buffer.lookup_transform(target, source, 0)
                        chain = buffer.chain(target, source)
                    except TransformException as exc:
                        if not told:
                            print(f'Waiting for transform chain to become available between '
                                  f'{target} and {source}: {exc}', file=sys.stderr)  # fmt: skip
                            told = True
                    else:
                        stamp = found.header.stamp
                        delays.sample_chain(stamp.sec * _NS + stamp.nanosec)
                if time.monotonic() < due:
                    continue
                due += args.period
                node.graph.refresh()  # broadcasters are named from the graph
                out(('\n\n' if reports else '') + delays.report(chain if args.frames else None))
                reports += 1
        except KeyboardInterrupt:
            pass
        finally:
            listener.unregister()
    return 0
