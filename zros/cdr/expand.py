"""A definition as ``ros2 interface show`` prints it: its text, nested types expanded beneath
their fields (one tab deeper), comments kept at the top level.

ros2interface (Jazzy) walks the definition file line by line and classifies each line with
rosidl_adapter's parser; zros follows the same rules so that the output is identical, quirks
included: a comment is a line starting with ``#`` whose text is not empty once a ``[unit]`` is
taken out (so a bare ``#``, or ``# [m]``, counts as text and survives ``--no-comments``); an
indented comment line is text too; a trailing comment is cut at one character before the
comment's text, which leaves the ``#``.

The text comes from the definition's own source when it was parsed from a file or bag, else from
a ``.msg``/``.srv``/``.action`` file of the same shape in a ROS install (``AMENT_PREFIX_PATH``,
or ROS 2 wheels in this Python environment): the rosbags typestores keep no comments. With
neither, the definition is rendered back to text: expanded, without comments.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

from zros.cdr.model import ActionDef, Definition, MessageDef, ServiceDef
from zros.cdr.parser import parse_definition, parse_message
from zros.cdr.render import render_definition
from zros.errors import ZrosError

if TYPE_CHECKING:
    from zros.cdr.registry import TypeRegistry

Comments = Literal['top', 'all', 'none']

_UNIT = re.compile(r'(\s*\[([^,\]]+)\])')
_SEPARATOR = '---'


@dataclass(frozen=True)
class _Line:
    """One line of a definition file, classified as rosidl_adapter classifies it."""

    text: str  #: the line as written, right-stripped
    is_comment: bool = False
    trailing: str | None = None  #: the text of a comment after a field or constant
    nested: str | None = None  #: the full name of the message type of a field


def _comment_text(comment: str) -> str | None:
    """A comment as rosidl keeps it: a lone ``[unit]`` removed, dedented; None when empty."""
    units = _UNIT.findall(comment)
    if len(units) == 1:
        comment = comment.replace(units[0][0], '')
    if not comment:
        return None
    return textwrap.dedent(comment)


def _classify(text: str, package: str) -> _Line:
    if text == _SEPARATOR:
        return _Line(text)
    line = text.replace('\t', ' ')
    if line.startswith('#'):
        return _Line(text, is_comment=_comment_text(line.lstrip('#')) is not None)
    code, hash_mark, comment = line.partition('#')
    if not code.strip():
        return _Line(text)  # empty, or an indented comment: rosidl ignores it
    nested = None
    try:
        parsed = parse_message(f'{package}/msg/Line', code)
    except ZrosError:
        parsed = None
    if parsed is not None and parsed.fields and parsed.fields[0].type.is_nested:
        nested = parsed.fields[0].type.base
    trailing = _comment_text(comment.lstrip('#')) if hash_mark else None
    return _Line(text, trailing=trailing, nested=nested)


def _shape(definition: Definition) -> object:
    """What must agree for a file's text to stand for a definition (defaults aside)."""
    if isinstance(definition, MessageDef):
        return (
            tuple((f.name, f.type) for f in definition.fields),
            tuple((c.name, c.type) for c in definition.constants),
        )
    if isinstance(definition, ServiceDef):
        return (_shape(definition.request), _shape(definition.response))
    assert isinstance(definition, ActionDef)
    return tuple(_shape(p) for p in (definition.goal, definition.result, definition.feedback))


def definition_text(registry: TypeRegistry, name: str) -> str:
    """The text of a type with its comments where some source has them, else rendered."""
    return _text(registry, name)[0]


def text_origin(registry: TypeRegistry, name: str) -> str | None:
    """Where the text :func:`definition_text` gives for ``name`` comes from (a file, a bag,
    registered text), or None when no source has it and it is rendered without comments."""
    return _text(registry, name)[1]


def _text(registry: TypeRegistry, name: str) -> tuple[str, str | None]:
    definition = registry.definition(name)
    if definition.source:
        return definition.source, definition.origin or '<registered text>'
    for path in registry.text_files(definition.name):
        try:
            text = path.read_text(encoding='utf-8')
            parsed = parse_definition(definition.name, text, str(path))
        except (OSError, UnicodeDecodeError, ZrosError):
            continue
        if _shape(parsed) == _shape(definition):
            return text, str(path)
    return render_definition(definition), None


def _show(
    registry: TypeRegistry, name: str, comments: bool, nested_comments: bool, depth: int
) -> list[str]:
    package = name.split('/', maxsplit=1)[0]
    lines = definition_text(registry, name).split('\n')
    if lines and lines[-1] == '':
        lines.pop()
    out: list[str] = []
    for raw in lines:
        line = _classify(raw.rstrip(), package)
        text = line.text
        if not comments:
            if not text or line.is_comment:
                continue
            if line.trailing is not None:
                text = text[: text.find(line.trailing) - 1].strip()
        out.append('\t' * depth + text if text else '')
        if line.nested:
            out += _show(registry, line.nested, nested_comments, nested_comments, depth + 1)
    return out


def expanded_text(registry: TypeRegistry, name: str, comments: Comments = 'top') -> str:
    """What ``ros2 interface show`` prints for ``name``: comments of the type itself
    (``'top'``, the default), of nested types too (``'all'``) or none (``'none'``)."""
    full = registry.definition(name).name
    lines = _show(registry, full, comments != 'none', comments == 'all', 0)
    return ''.join(line + '\n' for line in lines)


__all__ = ['Comments', 'definition_text', 'expanded_text', 'text_origin']
