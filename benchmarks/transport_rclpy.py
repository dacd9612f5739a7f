"""The rclpy rows of ``benchmarks/transport.py``: the same rows between two rclpy processes over
Fast DDS, inside a private network namespace (needs the ``interop`` extra and root)."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from typing import Any

from transport_roles import read_result, wait_ready

RCLPY_WORKER = r"""
import json, statistics, sys, time, threading
import numpy as np
import rclpy
from rclpy.qos import QoSProfile, HistoryPolicy, ReliabilityPolicy
from std_msgs.msg import String, Float64
from sensor_msgs.msg import Image
role, count = sys.argv[1], int(sys.argv[2])
rclpy.init()
node = rclpy.create_node('bench_' + role)
keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
if role in ('pub_string', 'pub_image'):
    msg_type = String if role == 'pub_string' else Image
    pub = node.create_publisher(msg_type, 'bench', keep_all)
    msg = msg_type()
    if msg_type is String:
        msg.data = 'hello zros, a short message'
    else:
        msg.height, msg.width, msg.encoding, msg.step = 1080, 1920, 'rgb8', 5760
        msg.data = np.random.default_rng(1).integers(0, 256, 1920 * 1080 * 3, dtype=np.uint8).tobytes()
    while pub.get_subscription_count() == 0:
        time.sleep(0.01)
    time.sleep(0.5)
    for _ in range(count):
        pub.publish(msg)
    time.sleep(2)
elif role in ('sub_string', 'sub_image'):
    msg_type = String if role == 'sub_string' else Image
    state = {'n': 0, 'first': 0.0, 'last': 0.0}
    def on(msg):
        now = time.perf_counter()
        if state['n'] == 0:
            state['first'] = now
        state['n'] += 1
        state['last'] = now
    node.create_subscription(msg_type, 'bench', on, keep_all)
    print('ready', flush=True)
    deadline = time.monotonic() + 120
    while state['n'] < count and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    size = 1920 * 1080 * 3 + 64 if msg_type is Image else 36
    print(json.dumps({'received': state['n'], 'rate': (state['n'] - 1) / max(state['last'] - state['first'], 1e-9), 'size': size}))
elif role == 'echo':
    pub = node.create_publisher(Float64, 'pong', 10)
    node.create_subscription(Float64, 'ping', pub.publish, 10)
    print('ready', flush=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
elif role == 'ping':
    got = []
    node.create_subscription(Float64, 'pong', got.append, 10)
    pub = node.create_publisher(Float64, 'ping', 10)
    while pub.get_subscription_count() == 0:
        time.sleep(0.01)
    time.sleep(0.5)
    times = []
    msg = Float64()
    for i in range(count + 100):
        got.clear()
        start = time.perf_counter()
        pub.publish(msg)
        while not got:
            rclpy.spin_once(node, timeout_sec=1.0)
        if i >= 100:
            times.append(time.perf_counter() - start)
    times.sort()
    print(json.dumps({'median': statistics.median(times), 'p99': times[int(len(times) * 0.99)]}))
node.destroy_node()
rclpy.shutdown()
"""


Spawn = Callable[[list[str]], 'subprocess.Popen[str]']


@contextlib.contextmanager
def dds_namespace(domain: int, what: str) -> Iterator[Spawn | None]:
    """``spawn(argv)``: Python processes in a private network namespace for Fast DDS (only
    ``lo``), deleted on exit; None (and a line saying why) without rclpy, root or iproute2."""
    try:
        import rclpy  # noqa: F401
    except ImportError:
        print(f'{what} skipped: the interop extra (ros-jazzy-rclpy) is not installed')
        yield None
        return
    if os.geteuid() != 0 or shutil.which('ip') is None:
        print(f'{what} skipped: a private network namespace for DDS needs root and iproute2')
        yield None
        return
    namespace = f'zros_bench_{os.getpid()}'
    subprocess.run(['ip', 'netns', 'add', namespace], check=True)
    try:
        subprocess.run(['ip', '-n', namespace, 'link', 'set', 'lo', 'up'], check=True)
        env = {
            **os.environ,
            'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp',
            'ROS_DOMAIN_ID': str(domain),
            'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4',  # like zros here: no shared memory
        }

        def spawn(argv: list[str]) -> subprocess.Popen[str]:
            command = ['ip', 'netns', 'exec', namespace, sys.executable, *argv]
            return subprocess.Popen(command, stdout=subprocess.PIPE, text=True, env=env)

        yield spawn
    finally:
        subprocess.run(['ip', 'netns', 'del', namespace], check=False)


def rclpy_rows(quick: bool) -> dict[str, dict[str, Any]] | None:
    """The String, Image and round-trip rows between two rclpy processes, or None."""
    with dds_namespace(42, 'rclpy row') as spawn_in:
        if spawn_in is None:
            return None

        def spawn(role: str, count: int) -> subprocess.Popen[str]:
            return spawn_in(['-c', RCLPY_WORKER, role, str(count)])

        rows: dict[str, dict[str, Any]] = {}
        for kind, count in (
            ('string', 20_000 if quick else 100_000),
            ('image', 50 if quick else 100),
        ):
            subscriber = spawn(f'sub_{kind}', count)
            wait_ready(subscriber)
            publisher = spawn(f'pub_{kind}', count)
            rows[kind] = read_result(subscriber, 300)
            publisher.communicate(timeout=120)
        echo = spawn('echo', 0)
        wait_ready(echo)
        rows['rtt'] = read_result(spawn('ping', 1000 if quick else 5000), 300)
        echo.kill()
        echo.communicate()
        return rows
