"""rosR tutorial, step 1: plot the voltage live, raw and through a moving-average filter.

Every reading is kept (``take()`` returns all unread messages, oldest first); a five-sample
moving average smooths the sensor's noise, as the paper's filter did. The figure is redrawn
twice a second while readings arrive: into ``rosr_demo1.png`` with matplotlib's Agg backend
(no display needed; an image viewer that reloads the file shows it live), or in a window with
``--show``.

With ``--connect`` (or ``ZROS_CONNECT``) it plots whatever publishes ``/sharpGP2D120/Voltage``
there; with neither, a router and the simulated sensor of ``sharp_sensor.py`` run inside it.
"""

from __future__ import annotations

import argparse
import time

import matplotlib
import numpy as np
from _bootstrap import ShowDefaults, add_connect, router_unless_given
from sharp_sensor import VOLTAGE_TOPIC, SimulatedSensor

import zros

WINDOW = 5  # samples in the moving average


def moving_average(values: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """The mean of each reading and the ``window - 1`` before it (shorter at the start)."""
    sums = np.cumsum(np.insert(values, 0, 0.0))
    counts = np.minimum(np.arange(1, len(values) + 1), window)
    starts = np.arange(1, len(values) + 1) - counts
    return (sums[1:] - sums[starts]) / counts


def main() -> int:
    parser = argparse.ArgumentParser(
        description='plot a GP2D120 voltage, raw and filtered', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--seconds', type=float, default=10.0, help='stop after this long')
    parser.add_argument('--output', default='rosr_demo1.png', help='the PNG to write')
    parser.add_argument('--show', action='store_true', help='draw in a window instead')
    args = parser.parse_args()
    if not args.show:
        matplotlib.use('Agg')  # files only, no display: before pyplot is imported
    import matplotlib.pyplot as plt

    sensor = None
    router, args.connect = router_unless_given(args.connect, 'a simulated sensor')

    zros.init('R_demo', connect=args.connect)
    sub = zros.Subscriber(VOLTAGE_TOPIC, 'std_msgs/msg/Float32', qos=1000)  # keep up to 1000
    if router is not None:
        sensor = SimulatedSensor(args.connect, calibration=False)

    figure, axes = plt.subplots(figsize=(8, 4))
    (raw_line,) = axes.plot([], [], '.', color='0.6', markersize=3, label='measured')
    (filtered_line,) = axes.plot([], [], '-', color='C3', label=f'moving average of {WINDOW}')
    axes.set(xlabel='reading', ylabel='voltage [V]', title=VOLTAGE_TOPIC)
    axes.legend(loc='upper left')
    if args.show:
        plt.ion()
        plt.show()

    volts: list[float] = []
    drawn = 0
    next_draw = time.monotonic()
    deadline = time.monotonic() + args.seconds
    while zros.ok() and time.monotonic() < deadline:
        zros.spin_once(timeout=0.02)
        volts.extend(message.data for message in sub.take())
        finished = sensor is not None and sensor.done and not sub.has_new_message()
        if len(volts) > drawn and (time.monotonic() >= next_draw or finished):
            data = np.array(volts)
            raw_line.set_data(np.arange(len(data)), data)
            filtered_line.set_data(np.arange(len(data)), moving_average(data))
            axes.relim()
            axes.autoscale_view()
            if args.show:
                plt.pause(0.001)
            else:
                figure.savefig(args.output, dpi=100)
            drawn = len(volts)
            next_draw = time.monotonic() + 0.5
        if finished:
            break

    if volts:
        smooth = moving_average(np.array(volts))
        print(f'plotted {len(volts)} readings into {args.output if not args.show else "a window"}')
        print(f'filtered voltage from {smooth.min():.2f} V to {smooth.max():.2f} V')
    if sensor is not None:
        sensor.stop()
    zros.shutdown()
    if router is not None:
        router.close()
    return 0 if volts else 1


if __name__ == '__main__':
    raise SystemExit(main())
