"""rosR tutorial, step 0: subscribe to a sensor's voltage and log it.

The rosR paper's first program, line for line in zros (rosR call on the right)::

    zros.init('R_demo')                                          # ros.Init
    sub = zros.Subscriber('/sharpGP2D120/Voltage', 'std_msgs/msg/Float32')   # ros.Subscriber
    while zros.ok():                                             # ros.OK
        zros.spin_once()                                         # ros.SpinOnce
        if sub.has_new_message():                                # ros.SubscriberHasNewMessage
            zros.info(f'Measured voltage {sub.read_message().data}')  # ros.ReadMessage, ros.Info

``read_message()`` gives the newest reading and drops older unread ones, as rosR did; ``take()``
would give all of them. Each ``zros.info`` line goes to the console (stderr) and to ``/rosout``,
where ``ros2 topic echo /rosout`` or rqt_console see it.

With ``--connect`` (or ``ZROS_CONNECT``) it listens to whatever publishes the voltage there: the
real sensor behind zenoh-bridge-ros2dds, or ``sharp_sensor.py``. With neither, it starts a Zenoh
router and the simulated sensor of ``sharp_sensor.py`` inside itself.
"""

from __future__ import annotations

import argparse
import time

from _bootstrap import ShowDefaults, add_connect, router_unless_given
from sharp_sensor import VOLTAGE_TOPIC, SimulatedSensor

import zros


def main() -> int:
    parser = argparse.ArgumentParser(
        description='log the voltage of a GP2D120 sensor', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--seconds', type=float, default=10.0, help='stop after this long')
    args = parser.parse_args()
    sensor = None
    router, args.connect = router_unless_given(args.connect, 'a simulated sensor')

    zros.init('R_demo', connect=args.connect)
    sub = zros.Subscriber(VOLTAGE_TOPIC, 'std_msgs/msg/Float32')
    if router is not None:
        sensor = SimulatedSensor(args.connect, calibration=False)

    logged = 0
    deadline = time.monotonic() + args.seconds
    while zros.ok() and time.monotonic() < deadline:
        zros.spin_once(timeout=0.01)
        if sub.has_new_message():
            volt = sub.read_message().data
            zros.info(f'Measured voltage {volt:.3f}')
            logged += 1
        elif sensor is not None and sensor.done:
            break  # the simulated sensor has said everything
    print(f'logged {logged} voltage readings (the newest at each spin) from {VOLTAGE_TOPIC}')
    if sensor is not None:
        sensor.stop()
    zros.shutdown()
    if router is not None:
        router.close()
    return 0 if logged else 1


if __name__ == '__main__':
    raise SystemExit(main())
