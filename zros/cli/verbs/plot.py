"""``zros plot`` (rqt_plot: live topics, or a recording).

It draws in a window when matplotlib has a display, else (or with ``--png``, ``--frames``)
into files through Agg. matplotlib is imported only when it runs.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from zros.cli.shared import CommandError, add_connection_options, open_node, out

if TYPE_CHECKING:
    from zros.plot.figure import SeriesFigure
    from zros.plot.live_plot import LivePlot
DEFAULT_PNG = 'zros_plot.png'  #: where a plot goes when there is no display and no --png


def _number(value: float) -> str:
    return f'{value:.6g}'


def _live_summary(plot: LivePlot) -> None:
    for series, stats in zip(plot.series, plot.stats, strict=True):
        if stats.count:
            out(
                f'{series.label}: {stats.count} values, min {_number(stats.minimum)}, '
                f'max {_number(stats.maximum)}'
            )
        else:
            out(f'{series.label}: no values')


def _bag_summary(plot: SeriesFigure) -> None:
    import numpy as np

    for series, line in zip(plot.series, plot.lines, strict=True):
        times = np.asarray(line.get_xdata(), np.float64)
        values = np.asarray(line.get_ydata(), np.float64)
        finite = values[np.isfinite(values)]
        if not finite.size:
            out(f'{series.label}: no values')
            continue
        out(
            f'{series.label}: {len(values)} values from {times.min():.3f} s to '
            f'{times.max():.3f} s, min {_number(finite.min())}, max {_number(finite.max())}'
        )


def _output(args: argparse.Namespace, show: bool) -> str | None:
    if show or args.png or args.frames:
        return str(args.png) if args.png else None
    out(f'no display: the plot goes into {DEFAULT_PNG} (--png FILE to choose)')
    return DEFAULT_PNG


def _plot_bag(args: argparse.Namespace) -> int:
    from zros.plot.bag_plot import bag_figure
    from zros.plot.figure import can_show

    for option, given in (
        ('--frames', args.frames),
        ('--duration', args.duration),
        ('--count', args.count),
        ('--window', args.window),
    ):
        if given is not None:
            raise CommandError(f'{option} is for live plots, not recordings')
    path, addresses = args.paths[0], args.paths[1:]
    if not addresses:
        raise CommandError(
            f'which fields of {path}? e.g. zros plot {path} /odom/twist/twist/linear/x'
        )
    show = not args.png and can_show()
    png = _output(args, show)
    plot = bag_figure(
        path, addresses, filter=args.filter, start=args.start, end=args.end, show=show
    )
    _bag_summary(plot)
    if png is not None:
        plot.save(png)
        out(f'wrote {png}')
    if show:
        import matplotlib.pyplot as plt

        plt.show()
    return 0


def _plot_live(args: argparse.Namespace) -> int:
    from zros.plot.figure import can_show
    from zros.plot.live_plot import LivePlot, run

    for option, given in (('--start', args.start), ('--end', args.end)):
        if given is not None:
            raise CommandError(f'{option} is for recordings (zros plot BAG /topic/field ...)')
    show = not (args.png or args.frames) and can_show()
    png = _output(args, show)
    window = 10.0 if args.window is None else (args.window if args.window > 0 else None)
    with open_node(args) as node:
        plot = LivePlot(
            node, args.paths, window=window, filter=args.filter, wait=args.wait, show=show
        )
        with plot:
            for series in plot.series:
                out(f'plotting {series.label} [{series.type_name}]')
            endless = args.duration is None and args.count is None and not show
            frames = run(
                plot,
                duration=args.duration,
                count=args.count,
                png=png,
                frames_dir=args.frames,
                show=show,
                interval=args.interval,
                started=(lambda: out('Ctrl-C to stop')) if endless else None,
            )
            _live_summary(plot)
    if png is not None:
        out(f'wrote {png}')
    if args.frames:
        out(f'wrote {frames} frames into {args.frames}')
    return 0


#: endings of recordings (a topic address cannot have them: ROS names have no dots)
BAG_SUFFIXES = ('.mcap', '.db3', '.bag')


def names_a_path(argument: str) -> bool:
    """Whether the first argument of ``zros plot`` can only be a file or folder: it does not
    start with ``/`` (every topic address does: ``~/bags``, ``./run1``, ``run1``) or it ends
    like a recording (``/data/run1.mcap``) or sits in a folder that exists, two levels deep or
    more (``/tmp/bags/run1``; a topic ``/run`` with field ``x`` stays an address)."""
    if not argument.startswith('/') or argument.lower().endswith(BAG_SUFFIXES):
        return True
    folder = Path(argument).parent
    return len(folder.parts) > 2 and folder.is_dir()


def plot(args: argparse.Namespace) -> int:
    from zros.plot.bag_plot import is_recording

    if args.filter is not None and args.filter < 1:
        raise CommandError(f'--filter is a number of values, 1 or more, not {args.filter}')
    first = args.paths[0]
    if is_recording(first):
        return _plot_bag(args)
    if names_a_path(first):  # not a topic address either: say so now, not after --wait
        bare = not first.startswith('/') and not first.lower().endswith(BAG_SUFFIXES)
        hint = ' (a topic address starts with /)' if bare else ''
        print(f'zros: error: no such file or folder: {first}{hint}', file=sys.stderr)
        return 2
    return _plot_live(args)


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    text = (
        'plot numeric fields of live topics (like rqt_plot), or of a recording when the first '
        'argument is a bag'
    )
    parser = commands.add_parser(
        'plot',
        help=help_line,
        description=text,
        epilog='examples: zros plot /imu/linear_acceleration/x /odom/twist/twist/linear/x '
        '--filter 5; zros plot /scan/ranges[0] --duration 10 --png scan.png; '
        'zros plot run1/ /odom/pose/pose/position --png odom.png',
    )
    parser.set_defaults(run=plot)
    parser.add_argument(
        'paths',
        nargs='+',
        metavar='ADDRESS',
        help='/topic/field/path (a message field: all its numbers; name[i]: an element); '
        'a bag (folder, .mcap, .db3, .bag) first plots from it',
    )
    parser.add_argument(
        '--window',
        type=float,
        metavar='S',
        help='live: seconds of the time axis (default 10; 0: everything)',
    )
    parser.add_argument(
        '--filter', type=int, metavar='N', help='add a moving average of N values over each line'
    )
    parser.add_argument('--duration', type=float, metavar='S', help='live: stop after S seconds')
    parser.add_argument(
        '--count', type=int, metavar='N', help='live: stop after N messages (all topics together)'
    )
    parser.add_argument(
        '--png',
        metavar='FILE',
        help='write the (last) picture into FILE (.png, .svg, .pdf); no window',
    )
    parser.add_argument(
        '--frames', metavar='DIR', help='live: write a PNG every --interval into DIR; no window'
    )
    parser.add_argument(
        '--interval',
        type=float,
        metavar='S',
        help='live: seconds between redraws (default 0.1 in a window, 0.5 for frames)',
    )
    parser.add_argument(
        '--wait',
        type=float,
        default=5.0,
        metavar='S',
        help='live: how long to wait for the topics to appear (default 5)',
    )
    parser.add_argument(
        '--start', type=float, metavar='S', help='bag: from S seconds after its start'
    )
    parser.add_argument(
        '--end', type=float, metavar='S', help='bag: up to S seconds after its start'
    )
    add_connection_options(parser)
