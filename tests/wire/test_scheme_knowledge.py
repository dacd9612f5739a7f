"""Scheme knowledge lives in zros.wire and zros.keyexpr: no other module names a scheme, or a
variable only a scheme reads, in its code (docstrings may mention them); the rest asks the
Wire or the table SCHEMES."""

from __future__ import annotations

import ast
from pathlib import Path

from zros.wire import SCHEMES, wire_class

PACKAGE = Path(__file__).resolve().parents[2] / 'zros'
OWNERS = ('wire', 'keyexpr')


def scheme_words() -> set[str]:
    """The schemes' names and the variables their session defaults read."""
    words = set(SCHEMES)
    for name in SCHEMES:
        session = wire_class(name).session
        words |= {session.config_file_variable or '', session.override_variable or ''}
    return words - {''}


def naming(source: str, words: set[str]) -> list[tuple[int, str]]:
    """The lines of ``source`` whose code has a string that is one of ``words``."""
    return [
        (node.lineno, node.value)
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.Constant) and node.value in words
    ]


def test_no_module_outside_the_wire_names_a_scheme() -> None:
    words = scheme_words()
    assert {'bridge', 'rmw_zenoh', 'ZENOH_SESSION_CONFIG_URI', 'ZENOH_CONFIG_OVERRIDE'} <= words
    found = {
        str(path.relative_to(PACKAGE)): lines
        for path in sorted(PACKAGE.rglob('*.py'))
        if path.relative_to(PACKAGE).parts[0] not in OWNERS
        and (lines := naming(path.read_text(), words))
    }
    assert found == {}


def test_a_scheme_named_in_code_is_found() -> None:
    code = "def _wire(value: str) -> bool:\n    '''Is it rmw_zenoh?'''\n    return value == 'rmw_zenoh'\n"
    assert naming(code, scheme_words()) == [(3, 'rmw_zenoh')]
