"""The tutorial's node, rosR's demo0 to demo3 in Python: log, filter, fit, publish ranges.

* demo0: each voltage read from ``/sharpGP2D120/Voltage`` is logged (``zros`` logging, to the
  console and ``/rosout``);
* demo1: a moving average of five readings smooths the sensor's noise (plotted live by
  :mod:`zros.demo.figures`);
* demo2: the calibration pairs are read out of the bag (``Bag.columns``, as rosR's
  ``ros.BagRead``) and ``dist ~ poly(volt, 8)`` is fitted to them by least squares;
* demo3: each filtered voltage becomes a ``sensor_msgs/msg/Range`` on
  ``/sharpGP2D120/Distance``: a header with the time and frame, infrared, the field of view and
  the 4 to 30 cm range of the datasheet.
"""

from __future__ import annotations

import os
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

import zros
from zros.bag import Bag
from zros.demo.sensor import (
    CALIBRATION_TOPIC,
    DISTANCE_TOPIC,
    FIELD_OF_VIEW,
    FRAME_ID,
    MAX_RANGE,
    MIN_RANGE,
    VOLTAGE_TOPIC,
)

if TYPE_CHECKING:
    import numpy.typing as npt
    from numpy.polynomial import Polynomial

DEGREE = 8  # R: poly(volt, 8)
WINDOW = 5  # readings in the moving average
INFRARED = 1  # sensor_msgs/msg/Range.INFRARED


def moving_average(
    values: npt.NDArray[np.float64], window: int = WINDOW
) -> npt.NDArray[np.float64]:
    """The mean of each value and the ``window - 1`` before it (fewer at the start)."""
    values = np.asarray(values, dtype=float)
    sums = np.cumsum(np.insert(values, 0, 0.0))
    counts = np.minimum(np.arange(1, len(values) + 1), window)
    starts = np.arange(1, len(values) + 1) - counts
    return np.asarray((sums[1:] - sums[starts]) / counts)


@dataclass
class Calibration:
    """The calibration pairs of a bag and the curve fitted to them."""

    volt: npt.NDArray[np.float64]  #: volts, one per pair
    dist: npt.NDArray[np.float64]  #: metres, one per pair
    curve: Polynomial  #: distance in metres as a polynomial of the voltage

    @property
    def residuals(self) -> npt.NDArray[np.float64]:
        """Measured minus fitted distance of each pair, in metres."""
        return np.asarray(self.dist - self.curve(self.volt))

    @property
    def rms_error(self) -> float:
        """The root mean square of the residuals, in metres."""
        return float(np.sqrt(np.mean(self.residuals**2)))

    def distance(self, volt: float) -> float:
        """The distance the curve gives for ``volt``, within the sensor's range.

        Voltages beyond the calibrated ones are taken as the nearest calibrated one (a
        polynomial of degree 8 turns wild outside its data); the result is clamped to the
        datasheet's 4 to 30 cm.
        """
        volt = min(max(volt, float(self.volt.min())), float(self.volt.max()))
        return min(max(float(self.curve(volt)), MIN_RANGE), MAX_RANGE)


def fit_curve(
    volt: npt.NDArray[np.float64], dist: npt.NDArray[np.float64], degree: int = DEGREE
) -> Polynomial:
    """``dist ~ poly(volt, degree)`` by least squares (as R's ``lm``), as a numpy Polynomial."""
    from numpy.polynomial import Polynomial  # noqa: PLC0415 (lazy: numpy, import time)

    curve: Polynomial = Polynomial.fit(
        np.asarray(volt, dtype=float), np.asarray(dist, dtype=float), degree
    )
    return curve


def read_calibration(bag: str | os.PathLike[str], degree: int = DEGREE) -> Calibration:
    """Read the calibration pairs out of a bag (``/sharpGP2D120/Linearization``) and fit them."""
    with Bag(os.fspath(bag)) as recording:
        columns = recording.columns(CALIBRATION_TOPIC, ['dist', 'volt'])
    volt = columns['volt'].astype(float)
    dist = columns['dist'].astype(float)
    return Calibration(volt, dist, fit_curve(volt, dist, degree))


class RangeNode:
    """The tutorial's node on ``node`` (its steps in :meth:`handle`, rosR-style polling).

    ``log_every``: log every that many voltages at INFO (every one at DEBUG).
    """

    def __init__(self, node: zros.Node, calibration: Calibration, log_every: int = 50) -> None:
        self.node = node
        self.calibration = calibration
        self.log_every = log_every
        self.voltages = node.create_subscription(
            'std_msgs/msg/Float32', VOLTAGE_TOPIC, qos='keep_all'
        )
        self.publisher = node.create_publisher('sensor_msgs/msg/Range', DISTANCE_TOPIC)
        self.range = zros.Message(
            'sensor_msgs/msg/Range',
            radiation_type=INFRARED,
            field_of_view=FIELD_OF_VIEW,
            min_range=MIN_RANGE,
            max_range=MAX_RANGE,
        )
        self.range.header.frame_id = FRAME_ID
        self._window: deque[float] = deque(maxlen=WINDOW)
        self.readings: list[float] = []  #: every voltage received, in order
        self.filtered: list[float] = []  #: the moving average after each
        self.distances: list[float] = []  #: every range published

    def handle(self) -> int:
        """Log, filter, convert and publish each voltage received since the last call."""
        logger = self.node.get_logger()
        handled = 0
        for message in self.voltages.take():  # every reading, oldest first
            volt = float(message.data)
            self.readings.append(volt)
            count = len(self.readings)
            logger.debug(f'Measured voltage {volt:.3f} V')  # demo0
            if count % self.log_every == 1 or self.log_every == 1:
                logger.info(f'Measured voltage {volt:.3f} V (reading {count})')
            self._window.append(volt)  # demo1
            smooth = sum(self._window) / len(self._window)
            self.filtered.append(smooth)
            self.range.range = self.calibration.distance(smooth)  # demo2's curve
            self.range.header.stamp = self.node.clock.now().to_msg()  # demo3
            self.publisher.write(self.range)
            self.distances.append(self.range.range)
            handled += 1
        return handled
