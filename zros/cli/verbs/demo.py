"""``zros demo``: the rosR tutorial from end to end, on a router inside this process.

The work is in :mod:`zros.demo`; this module only parses the arguments (it is imported for
every ``zros`` command, so it imports nothing heavy).
"""

from __future__ import annotations

import argparse

DESCRIPTION = """\
The rosR tutorial on a simulated Sharp GP2D120 infrared distance sensor, with no robot, no
configuration and no network beyond loopback. It makes (once; later runs reuse it) a rosbag2
MCAP bag of the sensor: 314 voltages on /sharpGP2D120/Voltage and 240 calibration pairs on
/sharpGP2D120/Linearization (rosR_demos/msg/Linearization); plays it on a Zenoh router inside
this process; and runs the tutorial's node, which logs the voltages, plots them with a moving
average, fits dist ~ poly(volt, 8) to the calibration pairs read from the bag, and publishes
sensor_msgs/Range on /sharpGP2D120/Distance. It prints a report (messages seen, the fitted
distances at 0.8 V and 2.0 V beside the paper's, the residual error) and leaves the bag and
three PNGs (voltage.png, fit.png, distance.png) in the output folder."""


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    """Add ``zros demo`` to the subcommands."""
    demo = commands.add_parser(
        'demo',
        help=help_line,
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    demo.add_argument(
        '-o', '--output', default='zros-demo', metavar='DIR',
        help='folder for the bag and the PNGs (default: ./zros-demo)',
    )  # fmt: skip
    demo.add_argument(
        '--rate', type=_positive, default=10.0,
        help='play the bag this many times faster than recorded (default: 10)',
    )  # fmt: skip
    demo.add_argument(
        '--gui', action='store_true',
        help='plot in windows (live) instead of only writing PNGs; close them to end',
    )  # fmt: skip
    demo.add_argument(
        '--regenerate', action='store_true', help='make the bag again even if one is there'
    )
    demo.add_argument(
        '--log-every', type=int, default=50, metavar='N',
        help='log every Nth voltage at INFO (default: 50; all of them at DEBUG)',
    )  # fmt: skip
    demo.set_defaults(run=run)


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f'must be positive, not {text}')
    return value


def run(args: argparse.Namespace) -> int:
    """Run the demo; 0 when every message arrived and the fit is within 10 % of the paper's,
    130 after Ctrl-C, else 1."""
    from zros.demo.run import run_demo

    result = run_demo(
        args.output,
        rate=args.rate,
        gui=args.gui,
        regenerate=args.regenerate,
        log_every=max(1, args.log_every),
    )
    if result.interrupted:
        return 130
    return 0 if result.ok else 1
