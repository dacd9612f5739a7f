"""Rewrites of a generated encoder's body, run after it is generated: what only the whole
body shows (which position counts are read again, whether every part is appended outside
blocks)."""

from __future__ import annotations

_BASE = '    '  # the indentation of the encoder's body
#: the first and the last line of an encoder's body (``parts_in_locals`` rewrites both)
PARTS = 'parts = []; _p = parts.append; r = 0'
JOIN = 'return join(parts)'


def parts_in_locals(lines: list[str]) -> list[str] | None:
    """The body with its parts in locals joined once, where every part is appended outside
    loops and branches (a list and its appends are a third of a small message's encode), and
    without the position count when nothing reads it (:func:`without_dead_counts` dropped
    its updates); None where parts are appended in blocks."""
    appended = {i for i, line in enumerate(lines) if '_p(' in line}
    if len(appended) < 2 or any(not lines[i].startswith(_BASE + '_p(') for i in appended):
        return None
    counted = any('-r &' in line for line in lines)
    names: list[str] = []
    body = []
    for i, line in enumerate(lines):
        if i in appended:
            names.append(f'q{len(names)}')
            body.append(f'{_BASE}{names[-1]} = {line[len(_BASE) + 3 : -1]}')
        elif line == _BASE + PARTS:
            body += [_BASE + 'r = 0'] if counted else []
        elif line == _BASE + JOIN:
            body.append(f'{_BASE}return join(({", ".join(names)},))')
        else:
            body.append(line)
    return body


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def without_dead_counts(lines: list[str]) -> list[str]:
    """The body without the updates of the position count ``r`` that nothing reads after
    them (those after the last alignment, unless a loop holding it reads them again)."""
    reads = [i for i, line in enumerate(lines) if '-r &' in line]
    start = 0
    if reads:
        start = reads[-1] + 1
        depth = _indent(lines[reads[-1]])
        for j in range(reads[-1] - 1, -1, -1):  # the loops around the last read
            if _indent(lines[j]) < depth:
                depth = _indent(lines[j])
                if lines[j].lstrip().startswith(('for ', 'while ')):
                    end = next(
                        (k for k in range(reads[-1] + 1, len(lines)) if _indent(lines[k]) <= depth),
                        len(lines),
                    )
                    start = max(start, end)
    body = lines[:start]
    for i in range(start, len(lines)):
        line = lines[i]
        alone = (
            bool(body)
            and body[-1].endswith(':')
            and (  # a block's only statement stays (it must have one)
                i + 1 == len(lines) or _indent(lines[i + 1]) < _indent(line)
            )
        )
        if alone or not line.lstrip().startswith('r += '):
            body.append(line)
    return body
