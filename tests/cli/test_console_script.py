"""The ``zros`` console script, run as a user runs it."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ZROS = shutil.which('zros', path=str(__import__('pathlib').Path(sys.executable).parent))


def run(*args: str) -> subprocess.CompletedProcess[str]:
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    return subprocess.run([ZROS, *args], capture_output=True, text=True, timeout=120, check=False)


def test_demo_runs_the_tutorial_on_an_embedded_router(tmp_path: Path) -> None:
    # the README's first command, as typed: everything lands in ./zros-demo (tests/demo/test_demo.py
    # checks the report and the figures)
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    result = subprocess.run(
        [ZROS, 'demo'], capture_output=True, text=True, timeout=120, check=False, cwd=tmp_path
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'router   in this process, at tcp/127.0.0.1:' in result.stdout
    assert (
        '314 sensor_msgs/Range published on /sharpGP2D120/Distance, 314 received' in result.stdout
    )
    assert sorted(p.name for p in (tmp_path / 'zros-demo').iterdir()) == [
        'distance.png',
        'fit.png',
        'sharpGP2D120',
        'voltage.png',
    ]


def test_interface_show_with_dependencies_and_hash() -> None:
    result = run('interface', 'show', 'std_msgs/msg/String', '--hash', '--no-comments')
    assert result.returncode == 0
    assert result.stdout == (
        'string data\n# RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18\n'
    )
    bundle = run('interface', 'show', 'geometry_msgs/PoseStamped', '--all').stdout
    assert (
        'MSG: geometry_msgs/Quaternion\nfloat64 x\nfloat64 y\nfloat64 z\nfloat64 w 1.0\n' in bundle
    )
    assert run('interface', 'show', 'example_interfaces/srv/AddTwoInts').stdout == (
        'int64 a\nint64 b\n---\nint64 sum\n'
    )


def test_interface_list_filters() -> None:
    result = run('interface', 'list', 'sensor_msgs/msg/Ima')
    assert result.stdout.split() == ['sensor_msgs/msg/Image']


def test_errors_exit_with_1_and_a_message() -> None:
    result = run('interface', 'show', 'nope_msgs/msg/Nope')
    assert result.returncode == 1
    assert result.stderr.startswith("zros: error: unknown ROS type 'nope_msgs/msg/Nope'; searched:")
    assert run('interface', 'frobnicate').returncode == 2
    assert run().returncode == 2
