"""A simulated Sharp GP2D120 infrared distance sensor: the subject of the rosR tutorial.

The GP2D120 measures 4 to 30 cm; its output voltage falls, not linearly, as an object moves
away. This script publishes what the tutorial's recording held:

* ``/sharpGP2D120/Voltage`` (``std_msgs/msg/Float32``): the voltage, while an object sweeps back
  and forth in front of the sensor (314 readings, like the paper's bag);
* ``/sharpGP2D120/Linearization`` (``rosR_demos/msg/Linearization``, our own type, defined in
  ``interfaces/rosR_demos/msg/Linearization.msg``): 240 calibration pairs, a distance measured
  by hand and the voltage read there, which ``rosr_demo2_fit.py`` fits a curve to.

The data is made up from a model of the sensor's characteristic with noise, the same on every
run (``zros.demo.sensor``, from which ``zros demo`` makes its bag). The tutorial scripts
(``rosr_demo*.py``) start this sensor inside themselves when they are given no robot; run it
alone to feed them, or any ROS tool, from another process::

    python sharp_sensor.py --connect tcp/127.0.0.1:7447
"""

from __future__ import annotations

import argparse
import threading
from pathlib import Path

from _bootstrap import ShowDefaults, add_connect, router_unless_given

import zros

# the sensor's model is zros's own, the one `zros demo` makes its bag from; the other examples
# import the topics and limits from here
from zros.demo.sensor import (  # noqa: F401
    CALIBRATION_TOPIC,
    LINEARIZATION,
    MAX_RANGE,
    MIN_RANGE,
    PAIRS,
    READINGS,
    VOLTAGE_TOPIC,
    calibration_pairs,
    readings,
    voltage_at,
)


def register_linearization() -> str:
    """Make the tutorial's custom message type known to zros (from our own ``.msg`` file).

    Setting ``ZROS_INTERFACE_PATH`` to the ``interfaces`` folder would do the same for every
    zros program, and the CLI (``zros interface show rosR_demos/msg/Linearization``).
    """
    definition = Path(__file__).with_name('interfaces') / 'rosR_demos/msg/Linearization.msg'
    zros.register_type(LINEARIZATION, definition.read_text())
    return LINEARIZATION


def run_sensor(
    node: zros.Node,
    *,
    rate: float = 200.0,
    calibration: bool = True,
    voltages: bool = True,
    wait: float = 5.0,
    stop: threading.Event | None = None,
) -> int:
    """Publish the calibration pairs, then the voltage readings at ``rate`` per second.

    Waits up to ``wait`` seconds for a subscriber on each topic first, so that listeners started
    before it miss nothing; stops early when ``stop`` is set. Returns how many it published.
    """
    stop = stop or threading.Event()
    sent = 0
    if calibration:
        register_linearization()
        pairs = node.create_publisher(LINEARIZATION, CALIBRATION_TOPIC, qos='keep_all')
        pairs.wait_for_subscribers(timeout=wait)
        for distance, volt in calibration_pairs():
            if stop.is_set():
                return sent
            pairs.write(zros.Message(LINEARIZATION, dist=distance, volt=volt))
            sent += 1
    if voltages:
        voltage = node.create_publisher('std_msgs/msg/Float32', VOLTAGE_TOPIC)
        voltage.wait_for_subscribers(timeout=wait)
        ticks = node.create_rate(rate)
        for _, volt in readings():
            if stop.is_set() or not node.ok():
                break
            voltage.write(zros.Message('std_msgs/msg/Float32', data=volt))
            sent += 1
            ticks.sleep()
    return sent


class SimulatedSensor:
    """The sensor on a node and a thread of its own, beside the caller's node.

    ``done`` tells whether it has published everything; ``stop()`` ends it early.
    """

    def __init__(self, connect: str | None, calibration: bool = True, voltages: bool = True):
        self.node = zros.Node('sharpGP2D120', connect=connect)
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=run_sensor,
            args=(self.node,),
            kwargs={'calibration': calibration, 'voltages': voltages, 'stop': self._stop},
            name='sharpGP2D120',
            daemon=True,
        )
        self._thread.start()

    @property
    def done(self) -> bool:
        """Whether the sensor has published all it had."""
        return not self._thread.is_alive()

    def stop(self) -> None:
        """Stop publishing and destroy the sensor's node."""
        self._stop.set()
        self._thread.join(10)
        self.node.destroy()


def main() -> int:
    parser = argparse.ArgumentParser(
        description='publish a simulated GP2D120 sensor', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--rate', type=float, default=200.0, help='voltage readings per second')
    parser.add_argument('--wait', type=float, default=5.0, help='seconds to wait for listeners')
    args = parser.parse_args()
    router, args.connect = router_unless_given(args.connect)
    if router is not None:
        args.wait = 0.0  # nobody else can be on a router that only this script knows
    node = zros.init('sharpGP2D120', connect=args.connect)
    print(
        f'publishing {PAIRS} pairs on {CALIBRATION_TOPIC} and {READINGS} readings on '
        f'{VOLTAGE_TOPIC} (waiting up to {args.wait:g} s for listeners on each)'
    )
    sent = run_sensor(node, rate=args.rate, wait=args.wait)
    print(f'published {sent} messages; the model gives 0.8 V at 16.4 cm and 2.0 V at 6.1 cm')
    zros.shutdown()
    if router is not None:
        router.close()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
