"""``python -m zros`` is the ``zros`` command (for where the console script is not on PATH)."""

from __future__ import annotations

import subprocess
import sys


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, '-m', 'zros', *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_python_m_zros_runs_the_command_line_under_its_own_name() -> None:
    result = _run('interface', 'show', 'std_msgs/msg/String', '--no-comments')
    assert (result.returncode, result.stdout) == (0, 'string data\n')
    assert _run('--help').stdout.startswith('usage: zros ')


def test_python_m_zros_exits_with_the_command_line_s_codes() -> None:
    unknown = _run('interface', 'show', 'nope_msgs/msg/Nope')
    assert unknown.returncode == 1
    assert unknown.stderr.startswith("zros: error: unknown ROS type 'nope_msgs/msg/Nope'")
    assert _run('frobnicate').returncode == 2
