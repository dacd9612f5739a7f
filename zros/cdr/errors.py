"""Errors of the interface and CDR layer."""

from __future__ import annotations

from zros.errors import ZrosError


class CdrError(ZrosError, ValueError):
    """A message could not be encoded or decoded.

    ``type_name`` is the ROS type, ``field`` the dotted path of the field that failed (empty when
    the failure is not tied to one field) and ``offset`` the byte offset in the buffer, counted
    from the first byte of the 4-byte encapsulation header (None for encoding errors).
    """

    def __init__(
        self, message: str, *, type_name: str = '', field: str = '', offset: int | None = None
    ) -> None:
        super().__init__(message)
        self.type_name = type_name
        self.field = field
        self.offset = offset


class InterfaceSyntaxError(ZrosError, ValueError):
    """A .msg, .srv or .action text does not parse.

    The message reads ``file:line:column: what was expected``, followed by the line and a caret.
    """

    def __init__(self, origin: str, line: int, column: int, problem: str, text: str = '') -> None:
        where = f'{origin}:{line}:{column}'
        message = f'{where}: {problem}'
        if text:
            message += f'\n    {text}\n    {" " * (column - 1)}^'
        super().__init__(message)
        self.origin = origin
        self.line = line
        self.column = column
        self.problem = problem


class UnknownTypeError(ZrosError, LookupError):
    """A ROS type name could not be resolved; the message lists every place that was searched."""

    def __init__(self, name: str, searched: list[str], hint: str = '') -> None:
        lines = [f'unknown ROS type {name!r}; searched:']
        lines += [f'  - {place}' for place in searched]
        if hint:
            lines.append(hint)
        super().__init__('\n'.join(lines))
        self.name = name
        self.searched = searched


class TypeNameError(ZrosError, ValueError):
    """A string is not a valid ROS type name."""
