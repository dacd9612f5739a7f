"""A robot and a laptop across a WAN: does a remote camera view slow the robot, and does
small urgent traffic still get through?

The path is tests/support/wan_rig.py: a router on the robot's side with the robot's node next
to it, the laptop's node behind a userspace proxy (50 ms each way, 10 Mbit/s, what waits at
the bottleneck and every Zenoh socket buffer sized to the bandwidth-delay product, 125 kB).
The robot publishes a 640x480 rgb8 camera (921,600 bytes, reliable keep last 1) at 10 Hz, 9 MB/s
into a link of 1.25 MB/s, and two small stamped topics at 10 Hz: ``/cmd_vel``
(TwistStamped; interactive_high by default) and ``/status`` (PoseStamped; data). The laptop
subscribes to all three. Reported per run:

* the robot's ``write()`` time for the camera (max and p99) and for the small topics (max), and
  how many frames the camera's thread managed in the time (the small topics have a thread of
  their own, as a control loop would);
* each small topic's delivery ratio and age on arrival (p50, p99; age = arrival - header stamp,
  one clock);
* the images that arrived, and their age; how many images were written after the last one to
  arrive, and how many the laptop fetched once the stream paused (zros.pubsub.tail).

``before`` restores the settings of zros before issue 38 through the QoS: reliable publishers
``block``, every message at priority ``data`` and not express, the router's large-payload rule
off. ``after`` is the defaults. Both wires.

    python benchmarks/wan.py [--seconds 10] [--wire bridge|rmw_zenoh] [--runs before,after]
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve()
sys.path[:0] = [str(HERE.parents[1])]


import zros  # noqa: E402
from tests.support.wan_rig import Wan, wan  # noqa: E402
from zros.qos import Congestion, Priority, QoS  # noqa: E402

RATE = 10.0  #: Hz of every topic
IMAGE = 640 * 480 * 3
SMALL = (
    ('/cmd_vel', 'geometry_msgs/msg/TwistStamped'),
    ('/status', 'geometry_msgs/msg/PoseStamped'),
)


@dataclass
class Arrivals:
    """What reached the laptop on one topic: each message's age on arrival."""

    ages: list[float] = field(default_factory=list)
    last: float = 0.0  #: monotonic time of the last arrival
    frame: str = ''  #: the frame id of the last arrival (the camera numbers its images)

    def on(self, message: zros.Message) -> None:
        stamp = message.header.stamp
        self.ages.append(time.time() - stamp.sec - stamp.nanosec * 1e-9)
        self.last = time.monotonic()
        self.frame = message.header.frame_id


def _stamp(message: zros.Message) -> zros.Message:
    now = time.time_ns()
    message.header.stamp.sec, message.header.stamp.nanosec = divmod(now, 10**9)
    return message


def _percentile(values: list[float], share: float) -> float:
    if not values:
        return float('nan')
    ordered = sorted(values)
    return ordered[max(0, math.ceil(len(ordered) * share) - 1)]


def _qos(before: bool, depth: int) -> QoS:
    if before:  # zros before issue 38: reliable publishers blocked, one priority for all
        return QoS(depth, congestion=Congestion.BLOCK, priority=Priority.DATA, express=False)
    return QoS(depth)


def run(wire: str, before: bool, seconds: float) -> dict[str, object]:
    """One run; its figures."""
    with wan(wire, large_payloads=not before) as rig:
        return _measure(rig, before, seconds)


def _measure(rig: Wan, before: bool, seconds: float) -> dict[str, object]:
    robot = rig.node('robot', remote=False)
    laptop = rig.node('laptop', remote=True)
    arrivals = {name: Arrivals() for name, _ in (*SMALL, ('/camera', ''))}
    seen = laptop.create_subscription(
        'sensor_msgs/msg/Image', '/camera', arrivals['/camera'].on, qos=_qos(False, 1)
    )
    for name, type_name in SMALL:
        laptop.create_subscription(type_name, name, arrivals[name].on, qos=100)
    camera = robot.create_publisher('sensor_msgs/msg/Image', '/camera', _qos(before, 1))
    small = [robot.create_publisher(t, n, _qos(before, 10)) for n, t in SMALL]
    for publisher in (camera, *small):
        if not publisher.wait_for_subscribers(10):
            raise RuntimeError(f'{publisher.topic} found no subscriber')
    stop = threading.Event()

    def spin() -> None:
        while not stop.is_set():
            laptop.spin_once(0.05)

    spinner = threading.Thread(target=spin, name='laptop spin', daemon=True)
    spinner.start()
    image = zros.Message(
        'sensor_msgs/msg/Image', height=480, width=640, encoding='rgb8', step=640 * 3,
        data=bytes(IMAGE),
    )  # fmt: skip
    camera_writes: list[float] = []
    small_writes: list[float] = []
    sent = {'/camera': 0, 'small': 0}
    start = time.monotonic()

    def loop(name: str, step: Callable[[], None]) -> None:
        # a camera driver and a control loop, each on a thread of its own as on a robot
        while time.monotonic() < start + seconds:
            step()
            sent[name] += 1
            time.sleep(max(0.0, start + sent[name] / RATE - time.monotonic()))

    def write_image() -> None:
        image.header.frame_id = str(sent['/camera'])
        before_write = time.perf_counter()
        camera.write(_stamp(image))
        camera_writes.append(time.perf_counter() - before_write)

    messages = [zros.Message(t) for _, t in SMALL]

    def write_small() -> None:
        for publisher, message in zip(small, messages, strict=True):
            before_write = time.perf_counter()
            publisher.write(_stamp(message))
            small_writes.append(time.perf_counter() - before_write)

    loops = [
        threading.Thread(target=loop, args=('/camera', write_image), name='camera'),
        threading.Thread(target=loop, args=('small', write_small), name='control'),
    ]
    for thread in loops:
        thread.start()
    for thread in loops:
        thread.join()
    planned = int(seconds * RATE)
    _drain(arrivals, timeout=30.0)
    stop.set()
    spinner.join(5)
    figures: dict[str, object] = {
        'frames written': f'{sent["/camera"]}/{planned}',
        'write max ms': max(camera_writes) * 1e3,
        'write p99 ms': _percentile(camera_writes, 0.99) * 1e3,
        'small write max ms': max(small_writes) * 1e3,
        'control loop turns': f'{sent["small"]}/{planned}',
    }
    for name, _ in SMALL:
        got = arrivals[name].ages
        figures[f'{name} delivered'] = f'{len(got)}/{sent["small"]}'
        figures[f'{name} age p50 s'] = _percentile(got, 0.5)
        figures[f'{name} age p99 s'] = _percentile(got, 0.99)
    images = arrivals['/camera'].ages
    figures['images delivered'] = f'{len(images)}/{sent["/camera"]}'
    figures['image age p50 s'] = _percentile(images, 0.5)
    figures['image age max s'] = max(images) if images else float('nan')
    last = arrivals['/camera'].frame
    figures['last image: written before the last'] = (
        str(sent['/camera'] - 1 - int(last)) if last else '-'
    )
    figures['images fetched after the stream'] = str(seen.recovered)
    return figures


def _drain(arrivals: dict[str, Arrivals], timeout: float) -> None:
    """Wait until nothing arrived for 5 s (what was on its way has, and the newest image the
    laptop asks for once the stream paused), at most ``timeout``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        last = max(a.last for a in arrivals.values())
        if time.monotonic() - last > 5.0:
            return
        time.sleep(0.2)


def _table(rows: list[tuple[str, dict[str, object]]]) -> str:
    names = list(rows[0][1])
    lines = ['| | ' + ' | '.join(label for label, _ in rows) + ' |', '|---' * (len(rows) + 1) + '|']
    for name in names:
        cells = []
        for _, figures in rows:
            value = figures[name]
            cells.append(f'{value:.3g}' if isinstance(value, float) else str(value))
        lines.append(f'| {name} | ' + ' | '.join(cells) + ' |')
    return '\n'.join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--seconds', type=float, default=10.0, help='per run (default 10)')
    parser.add_argument('--wire', choices=['bridge', 'rmw_zenoh'], action='append')
    parser.add_argument('--runs', default='before,after', help='before, after or both')
    args = parser.parse_args(argv)
    rows: list[tuple[str, dict[str, object]]] = []
    report: Callable[[str], None] = print
    for wire in args.wire or ['bridge', 'rmw_zenoh']:
        for which in args.runs.split(','):
            figures = run(wire, which == 'before', args.seconds)
            rows.append((f'{wire} {which}', figures))
            report(f'{wire} {which}: ' + ', '.join(f'{k} {v}' for k, v in figures.items()))
    report('')
    report(_table(rows))
    return 0


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        sys.exit(main())
