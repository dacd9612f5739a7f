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


class FieldError(ZrosError, TypeError, ValueError):
    """A message was given a field it does not have, or a value its field cannot hold.

    ``type_name`` is the message type the user built, ``field`` the dotted path of the field
    (``pose.position.xx``, ``markers[2].ns``). For an unknown field, ``fields`` lists the fields
    of the innermost type (``leaf_type``) and ``closest`` is the likeliest intended name, or ''.
    It is a TypeError (as Python's own error for an unknown keyword) and a ValueError (as a
    value out of range).
    """

    def __init__(
        self,
        type_name: str,
        field: str,
        reason: str = '',
        *,
        fields: tuple[str, ...] | None = None,
        leaf_type: str = '',
        closest: str = '',
    ) -> None:
        self.type_name = type_name
        self.field = field
        self.reason = reason
        self.fields = fields
        self.leaf_type = leaf_type or type_name
        self.closest = closest
        super().__init__(self._text())

    @classmethod
    def unknown(cls, type_name: str, name: str, fields: tuple[str, ...]) -> FieldError:
        """``type_name`` has no field ``name``; suggest the closest of ``fields``."""
        import difflib  # noqa: PLC0415 (only for an error)

        close = difflib.get_close_matches(name, fields, n=1, cutoff=0.5)
        return cls(type_name, name, fields=fields, closest=close[0] if close else '')

    def _text(self) -> str:
        if self.fields is None:
            return f'{self.type_name} field {self.field!r}: {self.reason}'
        prefix = self.field[: len(self.field) - len(self.field.rpartition('.')[2])]
        hint = f'did you mean {prefix + self.closest!r}? ' if self.closest else ''
        of = f' of {self.leaf_type}' if self.leaf_type != self.type_name else ''
        names = ', '.join(self.fields) or '(none)'
        return f'{self.type_name} has no field {self.field!r} ({hint}fields{of}: {names})'

    def inside(self, type_name: str, prefix: str) -> FieldError:
        """The same error seen from an enclosing message ``type_name`` at field ``prefix``."""
        return FieldError(
            type_name,
            f'{prefix}.{self.field}',
            self.reason,
            fields=self.fields,
            leaf_type=self.leaf_type,
            closest=self.closest,
        )
