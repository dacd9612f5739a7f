"""A simulated Sharp GP2D120 infrared distance sensor: the subject of the rosR tutorial.

The GP2D120 measures 4 to 30 cm; its output voltage falls, not linearly, as an object moves away.
The model below is a curve through the datasheet's characteristic and the rosR paper's fit
(2.95 V at 4 cm, 2.0 V at 6.1 cm, 0.8 V at 16.4 cm, 0.47 V at 30 cm). Readings carry the noise a
real one shows: about 20 mV of ripple from its pulsed LED, then the 10-bit analog-to-digital
converter (5 V reference) that reads it. Calibration pairs are quieter (each the average a
careful student writes down) but their distances are half a millimetre off, as a ruler is.

Everything is made from fixed seeds: the same numbers on every run and every machine.
"""

from __future__ import annotations

import math
import random
from importlib import resources

from zros.cdr import default_registry

VOLTAGE_TOPIC = '/sharpGP2D120/Voltage'
CALIBRATION_TOPIC = '/sharpGP2D120/Linearization'
DISTANCE_TOPIC = '/sharpGP2D120/Distance'
FRAME_ID = 'sharpGP2D120'
LINEARIZATION = 'rosR_demos/msg/Linearization'
MIN_RANGE, MAX_RANGE = 0.04, 0.30  # metres, from the datasheet
FIELD_OF_VIEW = 0.05  # radians, roughly the width of the GP2D120's beam
READINGS, PAIRS = 314, 240  # as many as the paper's bag held
#: the paper's fit: volts -> metres
PAPER_FIT = {0.8: 0.164, 2.0: 0.061}
ADC_STEP = 5.0 / 1024  # volts per count of a 10-bit converter with a 5 V reference


def voltage_at(distance: float) -> float:
    """The sensor's output in volts, without noise, for an object ``distance`` metres away."""
    return 0.1246 / (distance + 0.003) + 0.054


def adc(volts: float) -> float:
    """``volts`` as a 10-bit converter with a 5 V reference reads them (steps of 4.9 mV)."""
    return round(min(max(volts, 0.0), 5.0) / ADC_STEP) * ADC_STEP


def sweep(count: int = READINGS) -> list[float]:
    """Distances of an object moving from 5 to 29 cm and back, twice in 314 readings."""
    return [0.17 + 0.12 * math.sin(2 * math.pi * i / 157) for i in range(count)]


def readings(count: int = READINGS, seed: int = 2013) -> list[tuple[float, float]]:
    """``(distance, voltage)`` of each reading along :func:`sweep`, with noise."""
    noise = random.Random(seed)
    return [(d, adc(voltage_at(d) + noise.gauss(0.0, 0.02))) for d in sweep(count)]


def calibration_pairs(count: int = PAIRS, seed: int = 1) -> list[tuple[float, float]]:
    """``(distance, voltage)`` pairs over the sensor's range, as a careful student takes them."""
    noise = random.Random(seed)
    step = (MAX_RANGE - MIN_RANGE) / (count - 1)
    pairs = []
    for i in range(count):
        distance = MIN_RANGE + i * step + noise.gauss(0.0, 0.0005)  # half a millimetre off
        pairs.append((distance, adc(voltage_at(distance) + noise.gauss(0.0, 0.01))))
    return pairs


def linearization_definition() -> str:
    """The text of ``rosR_demos/msg/Linearization`` (``float32 dist``, ``float32 volt``).

    It is our own type, shipped inside zros as ``zros/demo/msg/Linearization.msg``.
    """
    return (resources.files('zros.demo') / 'msg' / 'Linearization.msg').read_text()


def register_linearization() -> str:
    """Make the tutorial's custom message type known to zros; returns its name.

    Setting ``ZROS_INTERFACE_PATH`` to a folder holding ``rosR_demos/msg/Linearization.msg``
    does the same for every zros program and the CLI.
    """
    registry = default_registry()
    if registry.find(LINEARIZATION) is None:
        registry.register_text(LINEARIZATION, linearization_definition(), 'zros.demo')
    return LINEARIZATION
