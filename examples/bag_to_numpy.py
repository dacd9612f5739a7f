"""A recording as numpy arrays and a matplotlib figure: the rosR tutorial's data, offline.

The rosR paper worked from a bag: voltages and calibration pairs recorded once, read into R with
``ros.BagRead``. This script makes such a bag and works from it:

1. it records ``/sharpGP2D120/Voltage`` and ``/sharpGP2D120/Linearization`` into a rosbag2 MCAP
   bag (``zros.bag.Recorder``, as ``ros2 bag record`` or ``zros bag record`` would) while the
   simulated sensor of ``sharp_sensor.py`` publishes them;
2. it opens the bag (``zros.bag.Bag``) and reads each topic into numpy arrays without a Python
   loop over messages: ``bag.columns(topic, fields)`` gives one array per field plus the receive
   times, ``bag.to_numpy(topic)`` one structured array;
3. it fits the calibration curve and plots the voltage over time into ``bag_to_numpy.png``.

The bag stays in ``sharp_sensor_bag/`` (``--keep`` to choose), for ``zros bag info``, ``zros
plot`` or the snippets of docs/bags.md; a second run reads it again instead of recording (delete
it to record anew). ``--bag PATH`` reads another existing bag with those topics (a folder, an
``.mcap``, a ``.db3`` or a ROS 1 ``.bag``). With ``--connect`` (or ``ZROS_CONNECT``) it records
what is published there (run ``sharp_sensor.py`` against the same router); with neither, a
router and the simulated sensor run inside it. Distances are in metres, as in ``zros demo``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib
import numpy as np
from _bootstrap import ShowDefaults, add_connect, router_unless_given
from sharp_sensor import (
    CALIBRATION_TOPIC,
    PAIRS,
    READINGS,
    VOLTAGE_TOPIC,
    SimulatedSensor,
    register_linearization,
)

import zros
from zros.bag import Bag, Recorder, bag_read


def record(connect: str | None, own_sensor: bool, path: Path, seconds: float) -> int:
    """Record the sensor's two topics into ``path``; returns how many messages were written."""
    node = zros.init('recorder', connect=connect)
    register_linearization()  # so that the bag carries the definition of our own type
    with Recorder(node, path, [VOLTAGE_TOPIC, CALIBRATION_TOPIC]) as recorder:
        sensor = SimulatedSensor(connect) if own_sensor else None
        deadline = time.monotonic() + seconds
        while recorder.message_count < READINGS + PAIRS and time.monotonic() < deadline:
            if sensor is not None and sensor.done and recorder.message_count:
                deadline = min(deadline, time.monotonic() + 1.0)  # the rest is in flight
            zros.spin_once(timeout=0.05)
        if sensor is not None:
            sensor.stop()
    zros.shutdown()
    return recorder.message_count


def main() -> int:
    parser = argparse.ArgumentParser(
        description='record the GP2D120 into a bag, read it back', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--bag', type=Path, help='read this recording instead of making one')
    parser.add_argument(
        '--keep',
        type=Path,
        default=Path('sharp_sensor_bag'),
        help='where the recording goes (and stays); read again if it is there already',
    )
    parser.add_argument('--seconds', type=float, default=20.0, help='record at most this long')
    parser.add_argument('--output', default='bag_to_numpy.png', help='the PNG to write')
    args = parser.parse_args()

    path = args.bag
    if path is None and args.keep.exists():
        path = args.keep
        print(f'reading {path}/, recorded before (delete it to record again)')
    elif path is None:
        router, args.connect = router_unless_given(args.connect, 'a simulated sensor')
        path = args.keep
        count = record(args.connect, router is not None, path, args.seconds)
        if router is not None:
            router.close()
        print(f'recorded {count} messages into {path}/ ({len(list(path.iterdir()))} files)')

    with Bag(path) as bag:
        for name, info in bag.topics.items():
            print(f'  {name}: {info.count} x {info.type_name}')
        voltage = bag.columns(VOLTAGE_TOPIC, ['data'])  # {'time': int64 ns, 'data': float32}
        pairs = bag.to_numpy(CALIBRATION_TOPIC)  # a record per message: time, dist, volt
    print(
        f'voltage: {voltage["data"].shape[0]} readings as {voltage["data"].dtype}, '
        f'mean {voltage["data"].mean():.3f} V'
    )
    print(f'calibration: a structured array of {len(pairs)} records, fields {pairs.dtype.names}')
    curve = np.polynomial.Polynomial.fit(pairs['volt'], pairs['dist'], 8)
    print(f'fitted from the bag: 0.8 V -> {curve(0.8):.3f} m, 2.0 V -> {curve(2.0):.3f} m')

    table = bag_read(path, [CALIBRATION_TOPIC])  # rosR's ros.BagRead: four columns
    print(
        f'bag_read: {len(table)} rows of topic, data_type, time_stamp, message; the first: '
        f'{table.data_type[0]} dist={table.message[0].dist:.3f}'
    )

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    seconds = (voltage['time'] - voltage['time'][0]) / 1e9
    figure, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
    top.plot(seconds, voltage['data'], '.', markersize=3)
    top.set(ylabel='voltage [V]', title=f'{VOLTAGE_TOPIC}, from the bag')
    bottom.plot(seconds, curve(voltage['data']), '.', markersize=3, color='C1')
    bottom.set(xlabel='receive time [s]', ylabel='distance [m] (fitted)')
    figure.savefig(args.output, dpi=100)
    print(f'plotted voltage [V] and fitted distance [m] over time into {args.output}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
