"""The command line as a whole: help everywhere, lazy start-up, interface verbs."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.cli.conftest import ZROS
from zros.cli.main import COMMANDS, build_parser


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

    walk(build_parser(), [])
    return found


@pytest.mark.parametrize('path', verbs(), ids=lambda path: ' '.join(path) or 'zros')
def test_every_command_has_help(path: list[str]) -> None:
    assert ZROS is not None
    result = subprocess.run(
        [ZROS, *path, '--help'], capture_output=True, text=True, timeout=60, check=False
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f'usage: zros {" ".join(path)}'.rstrip())


#: what no parser may import: the work of the commands imports these when it runs
HEAVY = ('zenoh', 'numpy', 'zros.cdr', 'ruamel', 'matplotlib')


def command_modules() -> set[str]:
    """The modules that add the parsers of the commands."""
    return {f'zros.cli.verbs.{command}' for command in COMMANDS}


#: runs the console script as the shell does, then lists the modules it imported (Python's
#: -X importtime report would miss those imported by importlib.import_module)
RUN_AND_LIST_MODULES = """
import atexit, runpy, sys
atexit.register(lambda: print('MODULES', *sorted(sys.modules), file=sys.stderr))
sys.argv[0] = sys.argv[1]
del sys.argv[1]
runpy.run_path(sys.argv[0], run_name='__main__')
"""


def imported_by(*args: str) -> set[str]:
    """The modules the ``zros`` console script imports for ``zros ARGS``."""
    assert ZROS is not None
    result = subprocess.run(
        [sys.executable, '-c', RUN_AND_LIST_MODULES, ZROS, *args],
        capture_output=True, text=True, timeout=60, check=True,
    )  # fmt: skip
    assert result.stdout.startswith(f'usage: zros {" ".join(args[:-1])}'.rstrip())
    listed = [line for line in result.stderr.splitlines() if line.startswith('MODULES ')]
    assert len(listed) == 1, result.stderr
    return set(listed[0].split()[1:])


def test_help_imports_no_command_module_nor_zenoh_nor_numpy() -> None:
    """Start-up stays fast (issue 16: ``zros --help`` under 0.1 s) because ``zros --help``
    imports only argparse and the table of commands: a command's module loads when it is chosen,
    and the work imports the rest when it runs."""
    imported = imported_by('--help')
    assert 'zros.cli.main' in imported
    assert not imported & command_modules()
    assert not {name for name in imported if name.startswith(HEAVY)}


def test_a_command_imports_only_its_own_module() -> None:
    imported = imported_by('topic', 'echo', '--help')
    assert imported & command_modules() == {'zros.cli.verbs.topic'}
    assert not {name for name in imported if name.startswith(HEAVY)}
    assert imported_by('graph', '--help') & command_modules() == {'zros.cli.verbs.graph'}


def test_every_verb_runs_a_function_of_its_command_module() -> None:
    """A command's module is found by its name, and each parser it builds that runs something
    has as ``run`` a function of that module (not, say, a parser of the same name)."""
    import argparse
    import inspect

    def leaves(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
        found = [parser]
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for child in action.choices.values():
                    found += leaves(child)
        return found

    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    checked = 0
    for name, command in commands.choices.items():
        for leaf in leaves(command):
            run = leaf.get_default('run')
            if run is None:
                continue
            assert inspect.isfunction(run), (leaf.prog, run)
            assert run.__module__.startswith('zros.cli.'), (leaf.prog, run.__module__)
            checked += 1
        assert f'zros.cli.verbs.{name}' in sys.modules
    assert checked >= 40


def test_top_level_help_is_the_same_with_every_command_built() -> None:
    """Each command's help line is written once, in the table: the whole tree (docs/cli.md,
    completion) lists the commands exactly as ``zros --help`` does."""
    assert build_parser().format_help() == build_parser(()).format_help()
    assert build_parser(('topic', 'graph')).format_help() == build_parser(()).format_help()


def test_a_mistyped_command_gets_the_list_of_commands() -> None:
    result = run('tpoic', 'list')
    assert result.returncode == 2
    assert result.stderr.startswith('usage: zros [-h] [--version] COMMAND ...\n')
    assert "zros: error: argument COMMAND: invalid choice: 'tpoic' (choose from" in result.stderr
    assert all(name in result.stderr.split('(choose from', 1)[1] for name in COMMANDS)


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


def test_completion_knows_every_command_and_verb() -> None:
    # ``zros completion`` builds every command's tree, not only its own
    script = run('completion', 'bash').stdout
    assert all(f'"{" ".join(path)}") words=' in script for path in verbs())


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


@pytest.mark.parametrize(
    ('number', 'noun', 'said'),
    [(0, 'topic', '0 topics'), (1, 'topic', '1 topic'), (2, 'node', '2 nodes')],
)
def test_counts_are_said_with_the_right_noun(number: int, noun: str, said: str) -> None:
    from zros.cli.shared import counted

    assert counted(number, noun) == said
