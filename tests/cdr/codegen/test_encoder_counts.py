"""The fast encoder drops the position count's updates that nothing reads, and only those."""

from __future__ import annotations

from zros.cdr.codegen.passes import without_dead_counts


def _body(text: str) -> list[str]:
    return ['    ' + line for line in text.strip('\n').splitlines()]


def test_updates_after_the_last_alignment_are_dropped() -> None:
    lines = _body("""
parts = []; _p = parts.append; r = 0
_p(a)
r += 4
k = -r & 7
_p(b[k])
r += k + 8
if n:
    _p(c)
    r += n
return join(parts)
""")
    assert without_dead_counts(lines) == _body("""
parts = []; _p = parts.append; r = 0
_p(a)
r += 4
k = -r & 7
_p(b[k])
if n:
    _p(c)
return join(parts)
""")


def test_a_loop_that_aligns_keeps_its_updates() -> None:
    lines = _body("""
parts = []; _p = parts.append; r = 0
for e in items:
    k = -r & 3
    _p(e[k])
    r += k + 4
    if e.n:
        _p(e.data)
        r += e.n
r += 4
return join(parts)
""")
    kept = without_dead_counts(lines)
    assert kept == [line for line in lines if line != '    r += 4']


def test_a_block_keeps_an_update_that_is_its_only_statement() -> None:
    lines = _body("""
parts = []; _p = parts.append; r = 0
if n:
    r += n
_p(a)
return join(parts)
""")
    assert without_dead_counts(lines) == lines
