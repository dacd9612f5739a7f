"""Python source under construction: its lines, the objects it refers to, and compiling it."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import partial
from typing import Any

from zros.cdr.errors import CdrError

#: a function compiled from generated source: what ``exec`` made, so its signature is known to
#: the source text only; each generator states it in its own return type (a precise Callable or
#: Protocol), so this is the one place a codec is unchecked, and nothing is cast per message
Generated = Callable[..., Any]  # type: ignore[explicit-any,unused-ignore]  # as above


class Program:
    """Python source under construction plus the objects it refers to.

    ``compile`` turns it into a function whose free names are those objects (bound once, as
    arguments of a factory), so generated code reads them as fast locals.
    """

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.depth = 1
        self.objects: dict[str, object] = {}
        self._ids: dict[int, str] = {}
        self._blanks: dict[type, str] = {}
        self._counter = 0
        self.trials = 0  #: how many :meth:`trial` blocks are open (their code is dropped)

    def add(self, line: str) -> None:
        """Append a line at the current indentation."""
        self.lines.append('    ' * self.depth + line)

    @contextmanager
    def block(self, header: str) -> Iterator[None]:
        """Lines added inside the ``with`` are indented under ``header``."""
        self.add(header)
        self.depth += 1
        yield
        self.depth -= 1

    @contextmanager
    def guarded(self, explain: object, arguments: str) -> Iterator[None]:
        """Lines added inside the ``with`` go in a ``try:`` whose ``except`` raises
        ``explain(arguments)`` instead (``exc`` names the exception caught)."""
        self.depth += 1
        start = len(self.lines)
        yield
        body = self.lines[start:]
        del self.lines[start:]
        self.depth -= 1
        self.add('try:')
        self.lines.extend(body)
        self.add('except Exception as exc:')
        self.add(f'    raise {self.ref(explain, "err")}({arguments}) from None')

    @contextmanager
    def trial(self) -> Iterator[None]:
        """Lines, names and objects added inside the ``with`` are dropped after it (a dry run
        that tells a generator what state some code would leave it in)."""
        lines, depth, counter = len(self.lines), self.depth, self._counter
        objects, ids, blanks = dict(self.objects), dict(self._ids), dict(self._blanks)
        self.trials += 1
        try:
            yield
        finally:
            self.trials -= 1
            del self.lines[lines:]
            self.depth, self._counter = depth, counter
            self.objects, self._ids, self._blanks = objects, ids, blanks

    def tmp(self, prefix: str) -> str:
        """A fresh name for a generated variable (``prefix`` and a number)."""
        self._counter += 1
        return f'{prefix}{self._counter}'

    def ref(self, obj: object, hint: str) -> str:
        """A name in the generated code that refers to ``obj``."""
        key = id(obj)
        if key not in self._ids:
            name = f'_{hint}{len(self._ids)}'
            self._ids[key] = name
            self.objects[name] = obj
        return self._ids[key]

    def blank(self, cls: type) -> str:
        """A name in the generated code of a function that makes a ``cls`` without running its
        ``__init__`` (a ``partial`` of ``object.__new__``: 6 ns faster per object than calling
        ``object.__new__(cls)``, which adds up in messages that hold many small structs)."""
        if cls not in self._blanks:
            self._blanks[cls] = self.ref(partial(object.__new__, cls), 'new')
        return self._blanks[cls]

    def compile(self, signature: str, name: str, type_name: str = '') -> Generated:
        """The function ``name(signature)`` with these lines as its body; CdrError when Python
        refuses it (a type nesting sequences deeper than its 20 nested blocks allow)."""
        params = ', '.join(self.objects)
        text = f'def _factory({params}):\n    def {name}({signature}):\n'
        text += '\n'.join('    ' + line for line in self.lines)
        text += f'\n    return {name}\n'
        scope: dict[str, Generated] = {}
        try:
            code = compile(text, f'<zros codec {name}>', 'exec')
        except (SyntaxError, RecursionError) as exc:
            subject = type_name or 'this type'
            raise CdrError(
                f'zros cannot generate the {name} function of {subject}: Python refuses it '
                f'({exc}); the type nests its fields too deeply',
                type_name=type_name,
            ) from None
        exec(code, scope)
        function: Generated = scope['_factory'](**self.objects)
        function.__zros_source__ = text  # type: ignore[attr-defined]  # read by source_of
        return function


def path_literal(path: str) -> str:
    """A field path as a Python literal (an f-string when it holds loop indexes)."""
    return 'f' + repr(path) if '{' in path else repr(path)


def source_of(function: object) -> str:
    """The generated source of a codec or method (for debugging)."""
    return str(getattr(function, '__zros_source__', ''))
