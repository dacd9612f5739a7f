"""The command line as a whole: help everywhere, lazy start-up, interface verbs."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.cli.conftest import ZROS
from zros.cli.main import _parser


def verbs() -> list[list[str]]:
    """Every ``zros COMMAND [VERB]`` the parser knows."""
    import argparse

    found: list[list[str]] = []

    def walk(parser: argparse.ArgumentParser, path: list[str]) -> None:
        found.append(path)
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, child in action.choices.items():
                    walk(child, [*path, name])

    walk(_parser(), [])
    return found


@pytest.mark.parametrize('path', verbs(), ids=lambda path: ' '.join(path) or 'zros')
def test_every_command_has_help(path: list[str]) -> None:
    assert ZROS is not None
    result = subprocess.run(
        [ZROS, *path, '--help'], capture_output=True, text=True, timeout=60, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f'usage: zros {" ".join(path)}'.rstrip())


def test_help_imports_neither_zenoh_nor_numpy() -> None:
    """Start-up stays fast (``zros --help`` in well under 0.3 s) because the parser imports
    only argparse and the command modules; the work imports the rest when it runs."""
    code = (
        'import sys, contextlib, io\n'
        'from zros.cli.main import main\n'
        'with contextlib.redirect_stdout(io.StringIO()), contextlib.suppress(SystemExit):\n'
        '    main(["--help"])\n'
        'print(sorted(m for m in ("zenoh", "numpy", "zros.cdr", "ruamel", "matplotlib")'
        ' if m in sys.modules))\n'
    )
    result = subprocess.run(
        [sys.executable, '-c', code], capture_output=True, text=True, timeout=60, check=True
    )
    assert result.stdout == '[]\n'


def run(*args: str) -> subprocess.CompletedProcess[str]:
    assert ZROS is not None
    return subprocess.run([ZROS, *args], capture_output=True, text=True, timeout=60, check=False)


def test_interface_packages_and_package() -> None:
    packages = run('interface', 'packages').stdout.split()
    assert {'std_msgs', 'sensor_msgs', 'std_srvs', 'rcl_interfaces'} <= set(packages)
    assert packages == sorted(packages)
    assert run('interface', 'package', 'std_srvs').stdout.split() == [
        'std_srvs/srv/Empty',
        'std_srvs/srv/SetBool',
        'std_srvs/srv/Trigger',
    ]
    missing = run('interface', 'package', 'nope_msgs')
    assert (missing.returncode, missing.stderr) == (
        1,
        'zros: error: no types of package nope_msgs (zros interface packages)\n',
    )
    actions = run('interface', 'list', '-a').stdout.split()
    assert 'example_interfaces/action/Fibonacci' in actions
    assert all('/action/' in name for name in actions)


@pytest.mark.parametrize(
    ('words', 'expected'),
    [
        ('zros to', 'topic'),
        ('zros topic e', 'echo'),
        ('zros topic echo /x --no', '--no-arr --no-str'),
        ('zros param d', 'delete describe dump'),
        ('zros topic echo /x --co', '--connect --count'),
    ],
)
def test_bash_completion(words: str, expected: str) -> None:
    bash = __import__('shutil').which('bash')
    if bash is None:
        pytest.skip('bash is not installed')
    script = run('completion', 'bash').stdout
    parts = words.split(' ')
    program = (
        f'{script}\nCOMP_WORDS=({" ".join(repr(p) for p in parts)}); '
        f'COMP_CWORD={len(parts) - 1}; _zros_complete; echo "${{COMPREPLY[@]}}"'
    )
    result = subprocess.run(
        [bash, '-c', program], capture_output=True, text=True, timeout=60, check=True
    )
    assert result.stdout == expected + '\n'
