"""No import circle runs through the message layer or the tools above the runtime.

``zros.cdr`` is imported by everything and ``bag``, ``plot``, ``demo`` and ``cli`` by nothing
below them, so none of their modules may sit on an import circle. Imports count wherever they
are written: inside functions and under ``TYPE_CHECKING`` too (as grimp and import-linter count
them), since a circle hidden in a function still ties the modules together.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import zros

ROOT = Path(zros.__file__).resolve().parent
#: packages whose modules must be on no circle, and the leaf modules they rely on
CHECKED = ('zros.cdr', 'zros.bag', 'zros.plot', 'zros.demo', 'zros.cli', 'zros.version')
#: file names the packages above may share with others because they mean the same thing
SHARED_NAMES = {'__init__.py', 'errors.py'}


def module_name(path: Path) -> str:
    parts = ['zros', *path.relative_to(ROOT).with_suffix('').parts]
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def imported(tree: ast.AST, modules: set[str]) -> Iterator[str]:
    """The zros modules a module's code imports, wherever the import statement is."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names if alias.name in modules)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                submodule = f'{node.module}.{alias.name}'
                if submodule in modules:
                    yield submodule
                elif node.module in modules:
                    yield node.module


def import_graph() -> dict[str, set[str]]:
    files = {module_name(path): path for path in ROOT.rglob('*.py')}
    modules = set(files)
    return {
        name: set(imported(ast.parse(path.read_text(encoding='utf-8')), modules)) - {name}
        for name, path in files.items()
    }


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            vertex, targets = work[-1]
            target = next(targets, None)
            if target is not None:
                if target not in index:
                    index[target] = low[target] = len(index)
                    stack.append(target)
                    on_stack.add(target)
                    work.append((target, iter(sorted(graph[target]))))
                elif target in on_stack:
                    low[vertex] = min(low[vertex], index[target])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[vertex])
            if low[vertex] == index[vertex]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == vertex:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def checked(module: str) -> bool:
    return any(module == package or module.startswith(package + '.') for package in CHECKED)


def test_the_circle_finder_finds_a_circle() -> None:
    graph = {'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}
    assert circles(graph) == [['a', 'b', 'c']]
    assert circles({'a': {'b'}, 'b': set()}) == []


def test_imports_in_functions_and_type_checking_blocks_count() -> None:
    code = 'if TYPE_CHECKING:\n    from zros.cdr import registry\ndef f():\n    import zros.bag\n'
    modules = {'zros.cdr', 'zros.cdr.registry', 'zros.bag'}
    assert set(imported(ast.parse(code), modules)) == {'zros.cdr.registry', 'zros.bag'}


def test_no_import_circle_runs_through_cdr_or_the_tools() -> None:
    on_circles = [c for c in circles(import_graph()) if any(checked(m) for m in c)]
    assert on_circles == [], on_circles


def test_the_tools_use_no_file_name_of_another_package() -> None:
    # the same file name in two packages reads as the same thing: cli/node.py is not zros/node.py
    names: dict[str, set[str]] = {}
    for path in ROOT.rglob('*.py'):
        names.setdefault(path.name, set()).add(module_name(path))
    twice = {
        name: sorted(modules)
        for name, modules in names.items()
        if name not in SHARED_NAMES and len(modules) > 1 and any(checked(m) for m in modules)
    }
    assert twice == {}
