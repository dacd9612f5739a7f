"""The layers of DESIGN.md hold, zros imports no module in a circle, and a file name means one
thing.

The contracts are ``[tool.importlinter]`` in pyproject.toml; ``lint-imports`` checks them on
the import graph grimp builds from the source. Imports count wherever they are written: inside
functions and under ``TYPE_CHECKING`` too, since a circle hidden in a function still ties the
modules together. A copy of the package with an upward import shows the contracts are checked.
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / 'zros'
#: file names used in several packages because they mean the same thing in each: a package's
#: errors, the client and server sides of services, actions, parameters and the gateways, and
#: a gateway's calls (the services its clients call)
SHARED_NAMES = {'__init__.py', 'errors.py', 'client.py', 'server.py', 'calls.py'}
#: the leaves of DESIGN.md's layers (packages and top-level modules)
LEAVES = {'bag', 'cli', 'demo', 'foxglove', 'gateway', 'plot', 'rosbridge', 'testing', 'tf'}

#: the modules of the ``zros`` commands, each named by its command (``zros tf`` is
#: ``verbs/tf.py``, beside the package ``zros.tf`` it drives): the one other rule for a name
VERBS = PACKAGE / 'cli' / 'verbs'


def lint_imports(cwd: Path, package_parent: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` with the contracts of ``cwd/pyproject.toml``, on the package found in
    ``package_parent``."""
    script = Path(sys.executable).parent / 'lint-imports'
    env = {**os.environ, 'PYTHONPATH': str(package_parent)}
    return subprocess.run(
        [str(script), '--config', str(cwd / 'pyproject.toml'), '--no-cache'],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip


def circles(package: str) -> list[list[str]]:
    """The strongly connected components (more than one module) of the import graph (Tarjan,
    iterative)."""
    graph = grimp.build_graph(package)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in sorted(graph.modules):
        if start in index:
            continue
        work = [(start, iter(sorted(graph.find_modules_directly_imported_by(start))))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            module, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    imported = sorted(graph.find_modules_directly_imported_by(child))
                    work.append((child, iter(imported)))
                elif child in on_stack:
                    low[module] = min(low[module], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[module])
            if low[module] == index[module]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == module:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_the_layer_contracts_hold() -> None:
    result = lint_imports(ROOT, ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert 'BROKEN' not in result.stdout and 'KEPT' in result.stdout


def test_an_upward_import_breaks_the_contracts(tmp_path: Path) -> None:
    shutil.copytree(PACKAGE, tmp_path / 'zros', ignore=shutil.ignore_patterns('__pycache__'))
    shutil.copy(ROOT / 'pyproject.toml', tmp_path / 'pyproject.toml')
    clock = tmp_path / 'zros' / 'runtime' / 'clock.py'
    clock.write_text(
        clock.read_text() + '\n\ndef _upward() -> None:\n    import zros.node  # noqa\n'
    )
    result = lint_imports(tmp_path, tmp_path)
    assert result.returncode != 0
    assert 'zros.runtime is not allowed to import zros.node' in result.stdout, result.stdout
    assert 'zros.runtime.clock -> zros.node' in result.stdout


def test_reading_a_bag_that_reaches_the_runtime_breaks_the_contracts(tmp_path: Path) -> None:
    shutil.copytree(PACKAGE, tmp_path / 'zros', ignore=shutil.ignore_patterns('__pycache__'))
    shutil.copy(ROOT / 'pyproject.toml', tmp_path / 'pyproject.toml')
    info = tmp_path / 'zros' / 'bag' / 'read' / 'info.py'
    info.write_text(info.read_text() + '\n\ndef _live() -> None:\n    import zros.pubsub  # noqa\n')
    result = lint_imports(tmp_path, tmp_path)
    assert result.returncode != 0
    assert 'zros.bag.read is not allowed to import zros.pubsub' in result.stdout, result.stdout


def test_a_scheme_key_module_imported_outside_the_wire_breaks_the_contracts(
    tmp_path: Path,
) -> None:
    """Only zros.wire (and zros.keyexpr) know the schemes: the graph asking a scheme's key
    module for a token is caught."""
    shutil.copytree(PACKAGE, tmp_path / 'zros', ignore=shutil.ignore_patterns('__pycache__'))
    shutil.copy(ROOT / 'pyproject.toml', tmp_path / 'pyproject.toml')
    view = tmp_path / 'zros' / 'graph' / 'view.py'
    view.write_text(view.read_text() + '\n\nfrom zros.keyexpr.rmw_zenoh import gid  # noqa\n')
    result = lint_imports(tmp_path, tmp_path)
    assert result.returncode != 0
    assert 'zros.graph is not allowed to import zros.keyexpr.rmw_zenoh' in result.stdout, (
        result.stdout
    )


def test_no_module_imports_itself_through_a_circle() -> None:
    assert circles('zros') == []


def test_the_circle_finder_finds_a_circle_through_functions_and_type_checking(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    package = tmp_path / 'knot'
    package.mkdir()
    (package / '__init__.py').write_text('')
    (package / 'a.py').write_text('def f() -> None:\n    from knot import b\n')
    (package / 'b.py').write_text(
        'from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from knot import c\n'
    )
    (package / 'c.py').write_text('import knot.a\n')
    (package / 'd.py').write_text('import knot.a\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    assert circles('knot') == [['knot.a', 'knot.b', 'knot.c']]


def test_no_file_name_means_two_things() -> None:
    # the same file name in two packages reads as the same thing: cli/node.py is not zros/node/
    names: dict[str, set[str]] = {}
    for path in PACKAGE.rglob('*.py'):
        if path.parent == VERBS:
            continue
        names.setdefault(path.name, set()).add(str(path.relative_to(ROOT)))
    twice = {
        name: sorted(paths)
        for name, paths in names.items()
        if name not in SHARED_NAMES and len(paths) > 1
    }
    assert twice == {}


def _private_names(tree: ast.Module) -> set[str]:
    """The underscored names a module defines: functions, classes, assigned names and
    attributes, ``__slots__`` entries."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            names.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            names.add(node.value)  # __slots__ entries, getattr names
    return {name for name in names if name.startswith('_') and not name.startswith('__')}


def leaf_reaches(package: Path) -> list[str]:
    """Where a leaf reads an underscored attribute that only the core defines (``x._name``,
    ``x`` not ``self``): the leaves use what the core makes public."""
    trees = {path: ast.parse(path.read_text()) for path in package.rglob('*.py')}
    by_part: dict[str, set[str]] = {}
    for path, tree in trees.items():
        part = path.relative_to(package).parts[0].removesuffix('.py')
        by_part.setdefault(part, set()).update(_private_names(tree))
    core = set().union(*(names for part, names in by_part.items() if part not in LEAVES))
    found = []
    for path, tree in trees.items():
        part = path.relative_to(package).parts[0].removesuffix('.py')
        if part not in LEAVES:
            continue
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and node.attr in core - by_part[part]
                and not (isinstance(node.value, ast.Name) and node.value.id == 'self')
            ):
                found.append(
                    f'{path.relative_to(package.parent)}:{node.lineno} {ast.unparse(node)}'
                )
    return found


def test_the_leaves_read_no_private_attribute_of_the_core() -> None:
    assert leaf_reaches(PACKAGE) == []


def test_a_leaf_reading_a_private_attribute_of_the_core_is_found(tmp_path: Path) -> None:
    copy = tmp_path / 'zros'
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns('__pycache__'))
    (copy / 'cli' / 'reach.py').write_text('def reach(message):\n    return message._definition\n')
    assert [reach.split(' ', 1)[1] for reach in leaf_reaches(copy)] == ['message._definition']


def test_a_verb_module_is_named_by_its_verb() -> None:
    """``zros.cli.verbs`` holds one module per command of ``zros``, named by it, and nothing
    else: the command line finds a command's module by its name."""
    from zros.cli.main import COMMANDS

    modules = {path.stem for path in VERBS.glob('*.py')} - {'__init__'}
    assert modules == set(COMMANDS)
    assert not [path for path in VERBS.iterdir() if path.is_dir() and path.name != '__pycache__']


#: folders of tests/ that are not one package's tests: suites across the packages, helpers,
#: and the tests of benchmarks/
SUITES = {'support', 'faults', 'interop', 'rmw', 'benchmarks'}
#: top-level test modules that check the repository as a whole rather than one module
REPOSITORY_CHECKS = {
    'architecture', 'docs_pages', 'docstrings', 'examples', 'lint', 'packaging', 'readme', 'typing',
}  # fmt: skip


def misplaced_tests(tests: Path, package: Path) -> list[str]:
    """Test folders that name no package of ``package`` and top-level test modules that name
    no module of it, apart from the suites and the repository's checks."""
    found = [
        str(folder.relative_to(tests))
        for folder in sorted(tests.rglob('*'))
        if (folder / '__init__.py').is_file()
        and folder != tests
        and folder.relative_to(tests).parts[0] not in SUITES
        and not (package / folder.relative_to(tests) / '__init__.py').is_file()
    ]
    for path in sorted(tests.glob('test_*.py')):
        name = path.stem.removeprefix('test_')
        if name not in REPOSITORY_CHECKS and not (package / f'{name}.py').is_file():
            found.append(path.name)
    return found


def test_tests_mirror_the_package() -> None:
    """DESIGN.md's rule: the tests of ``zros/<package>`` are in ``tests/<package>/``, those of
    a top-level module in ``tests/test_<module>.py``."""
    assert misplaced_tests(ROOT / 'tests', PACKAGE) == []


def test_a_misplaced_test_is_found(tmp_path: Path) -> None:
    tests = tmp_path / 'tests'
    for folder in ('graph', 'support', 'demo', 'bag/read', 'bag/reading'):
        (tests / folder).mkdir(parents=True)
        (tests / folder / '__init__.py').write_text('')
    for name in ('test_api.py', 'test_lint.py', 'test_demo.py'):
        (tests / name).write_text('')
    assert misplaced_tests(tests, PACKAGE) == ['bag/reading', 'test_demo.py']
