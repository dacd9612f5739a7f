"""The code base stays as the project's standards say: mypy --strict clean (the settings of
pyproject's [tool.mypy]) and ruff clean, lint and format, in the test command itself."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
#: the Python code of the repository (Markdown code blocks are prose, not checked here)
PYTHON_TREES = ['zros', 'tests', 'benchmarks', 'examples', 'docs']


def _tool(name: str) -> str:
    found = shutil.which(name, path=str(Path(sys.executable).parent))
    if found is None:
        pytest.skip(f'{name} is not installed in this environment (it comes with the test extra)')
    return found


def _run(command: list[str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        command, cwd=ROOT, capture_output=True, text=True, timeout=900, check=False
    )


def test_mypy_strict_is_clean() -> None:
    result = _run([_tool('mypy')])  # packages and strictness come from pyproject
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_lint_is_clean() -> None:
    result = _run([_tool('ruff'), 'check', *PYTHON_TREES])
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_format_is_clean() -> None:
    files = [str(p.relative_to(ROOT)) for tree in PYTHON_TREES for p in (ROOT / tree).rglob('*.py')]
    result = _run([_tool('ruff'), 'format', '--check', *files])
    assert result.returncode == 0, result.stdout + result.stderr
