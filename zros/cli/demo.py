"""``zros demo``: the rosR sensor tutorial, as far as zros runs it today.

A Sharp GP2D120 infrared sensor's output voltage falls as the distance grows. On a Zenoh router
inside this process, a simulated sensor publishes its voltage on ``/sharpGP2D120/Voltage``
(``std_msgs/Float32``); the tutorial's node, written as a rosR loop (init, spin once, has new,
read, write), smooths it with a moving average, converts it to a distance and publishes
``sensor_msgs/Range`` on ``/sharpGP2D120/Distance``.
"""

from __future__ import annotations

import argparse
import math
import random
import time
from collections import deque
from typing import Any

import zros
from zros.transport import Transport, TransportConfig, start_router

#: inverse model of the GP2D120 through the paper's fit (0.164 m at 0.8 V, 0.061 m at 2.0 V)
CURVE_GAIN = 0.11655  # metres times volts
CURVE_OFFSET = 0.0893  # volts
MIN_RANGE, MAX_RANGE = 0.04, 0.30  # metres, from the datasheet


def voltage_at(distance: float) -> float:
    """The sensor's output for an object at ``distance`` metres."""
    return CURVE_GAIN / distance + CURVE_OFFSET


def distance_at(voltage: float) -> float:
    """The distance the sensor sees at ``voltage`` (the inverse of :func:`voltage_at`)."""
    return CURVE_GAIN / max(voltage - CURVE_OFFSET, 1e-6)


def run(args: argparse.Namespace) -> int:
    """Run the tutorial's live part on an embedded router and print what flowed."""
    count = 200
    print('zros demo: the rosR sensor tutorial (stage 2: live topics on an embedded router)')
    with start_router() as router:
        print(f'  router inside this process: {router.endpoint}')
        settings: dict[str, Any] = {'connect': router.endpoint, 'shared_memory': False}
        sensor_session = Transport(TransportConfig.create(**settings))  # a process of its own
        sensor = zros.Node('sharpGP2D120', transport=sensor_session)
        voltage_pub = sensor.create_publisher('std_msgs/msg/Float32', '/sharpGP2D120/Voltage')

        zros.init('R_demo', config=TransportConfig.create(**settings), handle_sigint=False)
        try:
            sub = zros.Subscriber('/sharpGP2D120/Voltage', 'std_msgs/msg/Float32', qos=50)
            pub = zros.Publisher('/sharpGP2D120/Distance', 'sensor_msgs/msg/Range')
            ranges = zros.Subscriber('/sharpGP2D120/Distance', 'sensor_msgs/msg/Range', qos=count)
            if not (voltage_pub.wait_for_subscribers(5) and pub.wait_for_subscribers(5)):
                print('the demo nodes did not find each other')
                return 1
            rng = zros.Message(
                'sensor_msgs/msg/Range',
                radiation_type=1,  # INFRARED
                field_of_view=0.05,
                min_range=MIN_RANGE,
                max_range=MAX_RANGE,
            )
            rng.header.frame_id = 'sharpGP2D120'
            noise = random.Random(2013)
            window: deque[float] = deque(maxlen=5)  # the tutorial's moving-average filter
            sent = handled = 0
            started = time.monotonic()
            while zros.ok() and handled < count:
                if sent < count:  # the sensor: an object sweeping from 5 to 28 cm
                    distance = 0.165 + 0.115 * math.sin(sent / 15)
                    volt = voltage_at(distance) + noise.gauss(0, 0.01)
                    voltage_pub.write(zros.Message('std_msgs/msg/Float32', data=volt))
                    sent += 1
                zros.spin_once(timeout=0.002)
                if sub.has_new_message():
                    for message in sub.take():
                        window.append(message.data)
                        smoothed = sum(window) / len(window)
                        rng.range = min(max(distance_at(smoothed), MIN_RANGE), MAX_RANGE)
                        rng.header.stamp.sec, nanos = divmod(time.time_ns(), 1_000_000_000)
                        rng.header.stamp.nanosec = nanos
                        pub.write(rng)
                        handled += 1
                        if handled % 40 == 0:
                            print(f'  [R_demo] {smoothed:.3f} V (filtered) -> {rng.range:.3f} m')
            deadline = time.monotonic() + 2
            received: list[zros.cdr.Message] = []
            while len(received) < handled and time.monotonic() < deadline:
                message = ranges.wait_for_message(0.1)
                if message is not None:
                    received.append(message)
            elapsed = time.monotonic() - started
        finally:
            zros.shutdown()
            sensor.destroy()
            sensor_session.close()
    print(
        f'\n{sent} voltages published, {handled} converted, {len(received)} distances received '
        f'in {elapsed:.2f} s'
    )
    print(f'  0.8 V -> {distance_at(0.8):.3f} m, 2.0 V -> {distance_at(2.0):.3f} m (the curve)')
    print('Next stages (the calibration bag, the fitted curve, live plots) come with bags, plots.')
    return 0 if len(received) == handled == count else 1
