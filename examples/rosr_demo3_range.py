"""rosR tutorial, step 3: turn the voltage into distances and publish them as sensor_msgs/Range.

The tutorial's complete node. It fits the curve to the calibration pairs as step 2 does, then,
in a rosR-style loop, smooths each voltage reading with the moving average of step 1, converts
it with the curve and publishes a ``sensor_msgs/msg/Range`` on ``/sharpGP2D120/Distance``: a
header with the time and frame, the infrared radiation type, the field of view and the sensor's
4 to 30 cm range. Any ROS tool behind a bridge (``ros2 topic echo /sharpGP2D120/Distance``,
RViz, Foxglove) can read it; this script reads it back itself to show what went out.

With ``--connect`` (or ``ZROS_CONNECT``) it works on the topics there; with neither, a router
and the simulated sensor of ``sharp_sensor.py`` run inside it.
"""

from __future__ import annotations

import argparse
import time
from collections import deque

from _bootstrap import ShowDefaults, add_connect, router_unless_given
from rosr_demo2_fit import collect_pairs, fit_curve
from sharp_sensor import (
    CALIBRATION_TOPIC,
    MAX_RANGE,
    MIN_RANGE,
    PAIRS,
    VOLTAGE_TOPIC,
    SimulatedSensor,
    register_linearization,
)

import zros

DISTANCE_TOPIC = '/sharpGP2D120/Distance'


def main() -> int:
    parser = argparse.ArgumentParser(
        description='publish GP2D120 distances as sensor_msgs/Range', formatter_class=ShowDefaults
    )
    add_connect(parser)
    parser.add_argument('--seconds', type=float, default=10.0, help='stop after this long')
    args = parser.parse_args()
    sensor = None
    router, args.connect = router_unless_given(args.connect, 'a simulated sensor')

    zros.init('R_demo', connect=args.connect)
    pairs_sub = zros.Subscriber(CALIBRATION_TOPIC, register_linearization(), qos='keep_all')
    voltage_sub = zros.Subscriber(VOLTAGE_TOPIC, 'std_msgs/msg/Float32', qos=1000)
    range_pub = zros.Publisher(DISTANCE_TOPIC, 'sensor_msgs/msg/Range')
    echo = zros.Subscriber(DISTANCE_TOPIC, 'sensor_msgs/msg/Range', qos=1000)  # as ros2 would
    range_pub.wait_for_subscribers(timeout=5)
    print(f'waiting for calibration pairs on {CALIBRATION_TOPIC}')
    if router is not None:
        sensor = SimulatedSensor(args.connect)

    try:
        pairs = collect_pairs(pairs_sub, PAIRS, args.seconds)
        if len(pairs) < PAIRS // 2:
            print(f'only {len(pairs)} calibration pairs arrived on {CALIBRATION_TOPIC}: too few')
            return 1
        curve = fit_curve(pairs)
        print(f'curve fitted to the calibration pairs: 0.8 V -> {curve(0.8):.3f} m')

        rng = zros.Message(
            'sensor_msgs/msg/Range',
            radiation_type=1,  # Range.INFRARED
            field_of_view=0.05,  # radians, roughly the GP2D120's beam
            min_range=MIN_RANGE,
            max_range=MAX_RANGE,
        )
        rng.header.frame_id = 'sharpGP2D120'
        window: deque[float] = deque(maxlen=5)  # the moving average of step 1
        published = 0
        deadline = time.monotonic() + args.seconds
        while zros.ok() and time.monotonic() < deadline:  # ros.OK
            zros.spin_once(timeout=0.02)  # ros.SpinOnce
            if voltage_sub.has_new_message():  # ros.SubscriberHasNewMessage
                for reading in voltage_sub.take():  # every reading, oldest first
                    window.append(reading.data)
                    volt = sum(window) / len(window)
                    rng.range = min(max(float(curve(volt)), MIN_RANGE), MAX_RANGE)
                    rng.header.stamp = zros.time_now().to_msg()  # ros.TimeNow
                    range_pub.write(rng)  # ros.WriteMessage
                    published += 1
                    if published % 60 == 0:
                        zros.info(f'{volt:.3f} V -> {rng.range:.3f} m')
            elif sensor is not None and sensor.done:
                break

        received = []
        while len(received) < published:  # read back what went out, as any subscriber would
            message = echo.wait_for_message(timeout=2)
            if message is None:
                break
            received.append(message.range)
    finally:
        if sensor is not None:
            sensor.stop()
        zros.shutdown()
        if router is not None:
            router.close()
    print(f'published {published} sensor_msgs/Range on {DISTANCE_TOPIC}; read back {len(received)}')
    if received:
        print(f'distances from {min(received):.3f} m to {max(received):.3f} m')
    return 0 if published and len(received) == published else 1


if __name__ == '__main__':
    raise SystemExit(main())
