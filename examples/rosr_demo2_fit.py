"""rosR tutorial, step 2: fit the sensor's curve to calibration pairs.

Each ``rosR_demos/msg/Linearization`` message on ``/sharpGP2D120/Linearization`` is a distance
measured by hand (``dist``) and the voltage read there (``volt``). As the paper did in R
(``lm(dist ~ poly(volt, 8))``), this fits a polynomial of degree 8 giving the distance from the
voltage, prints what it predicts at 0.8 V and 2.0 V (the paper: 0.164 m and 0.061 m) and its
error on the pairs, and plots pairs and curve into ``rosr_demo2.png``.

The paper read the pairs out of its recorded bag with ``ros.BagRead``; here they arrive live, so
the subscriber keeps them all (``qos='keep_all'``). ``rosR_demos/msg/Linearization`` is our own
type: ``sharp_sensor.register_linearization()`` registers it from
``interfaces/rosR_demos/msg/Linearization.msg``.

With ``--connect`` (or ``ZROS_CONNECT``) it takes the pairs published there; with neither, a
router and the simulated sensor of ``sharp_sensor.py`` run inside it.
"""

from __future__ import annotations

import argparse
import time

import matplotlib
import numpy as np
from _bootstrap import ShowDefaults, add_connect, router_unless_given
from numpy.polynomial import Polynomial
from sharp_sensor import CALIBRATION_TOPIC, PAIRS, SimulatedSensor, register_linearization

import zros

DEGREE = 8


def collect_pairs(sub: zros.Subscriber, count: int, seconds: float) -> np.ndarray:
    """Up to ``count`` calibration pairs as an array of rows ``(dist, volt)``."""
    pairs: list[tuple[float, float]] = []
    deadline = time.monotonic() + seconds
    while zros.ok() and len(pairs) < count:
        message = sub.wait_for_message(timeout=max(0.0, deadline - time.monotonic()))
        if message is None:
            break  # nothing more in time
        pairs.append((message.dist, message.volt))
    return np.array(pairs, dtype=float).reshape(-1, 2)


def fit_curve(pairs: np.ndarray, degree: int = DEGREE) -> Polynomial:
    """The distance as a polynomial of the voltage, by least squares (R: ``poly(volt, 8)``)."""
    return Polynomial.fit(pairs[:, 1], pairs[:, 0], degree)


def main() -> int:
    parser = argparse.ArgumentParser(
        description='fit a GP2D120 curve to calibration pairs', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--count', type=int, default=PAIRS, help='calibration pairs to wait for')
    parser.add_argument('--seconds', type=float, default=10.0, help='give up after this long')
    parser.add_argument('--output', default='rosr_demo2.png', help='the PNG to write')
    args = parser.parse_args()
    sensor = None
    router, args.connect = router_unless_given(args.connect, 'a simulated sensor')

    zros.init('R_demo', connect=args.connect)
    linearization = register_linearization()
    sub = zros.Subscriber(CALIBRATION_TOPIC, linearization, qos='keep_all')
    if router is not None:
        sensor = SimulatedSensor(args.connect, voltages=False)
    pairs = collect_pairs(sub, args.count, args.seconds)
    if sensor is not None:
        sensor.stop()
    zros.shutdown()
    if router is not None:
        router.close()
    if len(pairs) <= DEGREE:
        print(f'only {len(pairs)} calibration pairs arrived on {CALIBRATION_TOPIC}: too few to fit')
        return 1

    curve = fit_curve(pairs)
    residuals = pairs[:, 0] - curve(pairs[:, 1])
    print(f'fitted dist ~ poly(volt, {DEGREE}) to {len(pairs)} pairs')
    print(f'  0.8 V -> {curve(0.8):.3f} m   (the paper: 0.164 m)')
    print(f'  2.0 V -> {curve(2.0):.3f} m   (the paper: 0.061 m)')
    print(f'  residual error {1000 * np.sqrt(np.mean(residuals**2)):.1f} mm (root mean square)')

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(6, 4))
    axes.plot(pairs[:, 1], pairs[:, 0], '.', color='0.5', markersize=4, label='calibration')
    volts = np.linspace(pairs[:, 1].min(), pairs[:, 1].max(), 200)
    axes.plot(volts, curve(volts), color='C0', label=f'polynomial of degree {DEGREE}')
    axes.set(xlabel='voltage [V]', ylabel='distance [m]', title='GP2D120 characteristic')
    axes.legend()
    figure.savefig(args.output, dpi=100)
    print(f'plotted pairs and curve into {args.output}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
