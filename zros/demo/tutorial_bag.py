"""The tutorial's bag: what the rosR paper recorded from its GP2D120, made from the sensor model.

A rosbag2 folder (``metadata.yaml`` and one MCAP file) holding, as the paper's bag did,

* ``/sharpGP2D120/Linearization`` (``rosR_demos/msg/Linearization``): 240 calibration pairs,
  at 50 a second;
* ``/sharpGP2D120/Voltage`` (``std_msgs/msg/Float32``): 314 readings at 25 a second (the
  GP2D120 measures every 38 ms or so) while an object sweeps from 5 to 29 cm and back.

It is written once, byte for byte the same every time (fixed seeds, fixed times starting at noon
on 1 June 2013 UTC, the paper's year), and reused while it is there and complete.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from zros.bag import Bag, BagTopic, BagWriter
from zros.cdr import default_registry, encode, get_class
from zros.demo.sensor import (
    CALIBRATION_TOPIC,
    LINEARIZATION,
    PAIRS,
    READINGS,
    VOLTAGE_TOPIC,
    calibration_pairs,
    readings,
    register_linearization,
)
from zros.errors import ZrosError
from zros.qos import QoS

BAG_NAME = 'sharpGP2D120'
#: written into the bag's ``custom_data``; a bag of another model version is made again
MODEL_VERSION = '1'
MODEL_KEY = 'zros_demo_model'
VOLTAGE_HZ = 25.0
CALIBRATION_HZ = 50.0
START_NS = 1_370_088_000 * 1_000_000_000  # 2013-06-01 12:00:00 UTC
_NS = 1_000_000_000
#: the sweep starts this long after the last calibration pair
GAP_NS = _NS


def write_bag(path: str | os.PathLike[str]) -> Path:
    """Write the tutorial's bag into the new folder ``path`` (it must not exist); returns it."""
    register_linearization()
    registry = default_registry()
    pair_class = get_class(LINEARIZATION)
    voltage_class = get_class('std_msgs/msg/Float32')
    with BagWriter(path, custom_data={MODEL_KEY: MODEL_VERSION}) as writer:
        pairs = writer.add_topic(
            BagTopic.from_registry(registry, CALIBRATION_TOPIC, LINEARIZATION, [QoS(10)])
        )
        voltages = writer.add_topic(
            BagTopic.from_registry(registry, VOLTAGE_TOPIC, 'std_msgs/msg/Float32', [QoS(10)])
        )
        stamp = START_NS
        for index, (distance, volt) in enumerate(calibration_pairs()):
            stamp = START_NS + round(index * _NS / CALIBRATION_HZ)
            writer.write(pairs, stamp, encode(pair_class(dist=distance, volt=volt)))
        sweep_start = stamp + GAP_NS
        for index, (_, volt) in enumerate(readings()):
            stamp = sweep_start + round(index * _NS / VOLTAGE_HZ)
            writer.write(voltages, stamp, encode(voltage_class(data=volt)))
    return writer.path


def bag_problem(path: str | os.PathLike[str]) -> str | None:
    """Why the folder ``path`` is not a complete tutorial bag of this model, or None if it is."""
    folder = Path(path)
    metadata = folder / 'metadata.yaml'
    if not metadata.is_file():
        return 'no metadata.yaml'
    from ruamel.yaml import YAML  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    try:
        info = YAML(typ='safe').load(metadata.read_text())['rosbag2_bagfile_information']
        custom = info.get('custom_data') or {}
    except Exception as exc:  # any unreadable metadata means: make the bag again
        return f'unreadable metadata.yaml ({exc})'
    if str(custom.get(MODEL_KEY)) != MODEL_VERSION:
        return f'made by another version of the model ({custom.get(MODEL_KEY)})'
    try:
        with Bag(folder) as bag:
            counts = {name: topic.count for name, topic in bag.topics.items()}
    except ZrosError as exc:
        return f'unreadable ({exc})'
    expected = {CALIBRATION_TOPIC: PAIRS, VOLTAGE_TOPIC: READINGS}
    if counts != expected:
        return f'it holds {counts}, not {expected}'
    return None


def _is_bag_folder(folder: Path) -> bool:
    """Whether ``folder`` holds nothing but what a bag writer leaves (safe to replace)."""
    return all(
        entry.is_file() and (entry.name == 'metadata.yaml' or entry.suffix == '.mcap')
        for entry in folder.iterdir()
    )


def ensure_bag(folder: str | os.PathLike[str], regenerate: bool = False) -> tuple[Path, bool]:
    """The tutorial's bag at ``folder/sharpGP2D120``, written unless a good one is there.

    Returns the bag's path and whether it was written now. A bag that is incomplete or of
    another model version is replaced (when the folder holds only bag files); ``regenerate``
    replaces it anyway. The bag is written in a folder beside and moved into place, so an
    interrupted run never leaves half a bag where the next run looks.
    """
    path = Path(folder) / BAG_NAME
    if path.exists():
        if not regenerate and bag_problem(path) is None:
            return path, False
        if not path.is_dir() or not _is_bag_folder(path):
            raise ZrosError(
                f'{path} is in the way of the demo bag and holds more than a bag: '
                'move it away or choose another --output'
            )
        shutil.rmtree(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    staging = path.with_name(f'.{BAG_NAME}.partial-{os.getpid()}')
    shutil.rmtree(staging, ignore_errors=True)
    try:
        write_bag(staging / BAG_NAME)  # file names inside the bag follow the folder's name
        (staging / BAG_NAME).rename(path)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return path, True
