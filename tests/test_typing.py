"""Code that uses zros type-checks under mypy --strict (zros ships py.typed)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import zros

USER_CODE = """
import zros
from zros import cdr

def relay(node: zros.Node) -> zros.Publisher:
    pub = node.create_publisher('sensor_msgs/msg/Range', 'distance', qos='sensor_data')
    def on_voltage(message: cdr.Message) -> None:
        rng = zros.Message('sensor_msgs/msg/Range', min_range=0.04)
        rng.range = 0.2 / message.data
        rng.header.frame_id = 'sharp'
        pub.write(rng)
    node.create_subscription('std_msgs/msg/Float32', 'voltage', on_voltage)
    return pub

def decode_twist(data: bytes) -> float:
    twist = cdr.decode('geometry_msgs/msg/Twist', data)
    speed: float = twist.linear.x
    return speed

qos: zros.QoS = zros.QoS(5, zros.Reliability.BEST_EFFORT)

def serve(node: zros.Node) -> None:
    def add(request: cdr.Message) -> cdr.Message:
        return zros.Message('example_interfaces/srv/AddTwoInts_Response', sum=request.a + request.b)
    def add_rclpy(request: cdr.Message, response: cdr.Message) -> cdr.Message:
        response.sum = request.a + request.b
        return response
    async def add_async(request: cdr.Message) -> cdr.Message:
        return add(request)
    node.create_service('example_interfaces/srv/AddTwoInts', 'add', add)
    node.create_service('example_interfaces/srv/AddTwoInts', 'add_rclpy', add_rclpy)
    node.create_service('example_interfaces/srv/AddTwoInts', 'add_async', add_async)
    zros.Service('add_lambda', 'example_interfaces/srv/AddTwoInts', lambda request: request, node=node)

def gain(node: zros.Node) -> float:
    value = node.get_parameter('gain')
    return float(value) if isinstance(value, (int, float)) else 1.0
"""


def test_user_code_passes_mypy_strict(tmp_path: Path) -> None:
    if shutil.which('mypy', path=str(Path(sys.executable).parent)) is None:
        pytest.skip('mypy is not installed in this environment')
    program = tmp_path / 'user_program.py'
    program.write_text(USER_CODE)
    # mypy does not follow the import hooks of editable installs: point it at the package
    package_root = Path(zros.__file__).resolve().parent.parent
    result = subprocess.run(
        [sys.executable, '-m', 'mypy', '--strict', '--no-incremental', str(program)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        env={**os.environ, 'MYPYPATH': str(package_root)},
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
