"""Parse ROS interface text (.msg, .srv, .action) into definitions.

The grammar is that of ROS 2 rosidl with the ROS 1 conveniences real bags still contain
(``Header``, ``time``, ``duration``, ``pkg/Type`` references, CamelCase field names). Errors name
the origin, line and column and say what was expected.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

from zros.cdr.errors import InterfaceSyntaxError
from zros.cdr.model import (
    INTEGER_RANGES,
    PRIMITIVE_SIZES,
    STRING_TYPES,
    ActionDef,
    Constant,
    DefaultValue,
    Definition,
    Field,
    FieldType,
    Kind,
    MessageDef,
    ServiceDef,
    Value,
    split_type_name,
)

_IDENT = re.compile(r'[A-Za-z][A-Za-z0-9_]*')
_TYPE = re.compile(
    r'(?P<base>[A-Za-z][A-Za-z0-9_]*(?:/[A-Za-z][A-Za-z0-9_]*){0,2})'
    r'(?:<=(?P<sbound>[0-9]+))?'
    r'(?:\[(?P<shape>[^\]]*)\])?$'
)
_SEPARATOR = re.compile(r'^\s*---\s*$')
_BUNDLE_RULE = re.compile(r'^={3,}\s*$')
_BUNDLE_HEADER = re.compile(r'^MSG:\s*(\S+)\s*$')

#: ROS 1 names that ROS 2 spells differently.
_ROS1_ALIASES = {
    'time': 'builtin_interfaces/msg/Time',
    'duration': 'builtin_interfaces/msg/Duration',
    'Header': 'std_msgs/msg/Header',
}


@dataclass
class _Line:
    number: int
    text: str  #: the line without its comment, right-stripped
    raw: str  #: the line as written


class _Source:
    def __init__(self, origin: str) -> None:
        self.origin = origin

    def error(self, line: _Line, column: int, problem: str) -> InterfaceSyntaxError:
        return InterfaceSyntaxError(self.origin, line.number, column, problem, line.raw.rstrip())


def _strip_comment(text: str) -> str:
    """Cut a ``#`` comment, ignoring ``#`` inside quoted strings."""
    quote = ''
    escaped = False
    for index, char in enumerate(text):
        if escaped:
            escaped = False
        elif char == '\\':
            escaped = True
        elif quote:
            if char == quote:
                quote = ''
        elif char in '"\'':
            quote = char
        elif char == '#':
            return text[:index]
    return text


def _lines(text: str, first_number: int = 1) -> list[_Line]:
    result = []
    for offset, raw in enumerate(text.replace('\t', ' ').splitlines()):
        result.append(_Line(first_number + offset, _strip_comment(raw).rstrip(), raw))
    return result


def _resolve_base(base: str, package: str) -> str | None:
    """Full name of a base type written in a .msg file, or None when it is malformed."""
    if base in PRIMITIVE_SIZES or base in STRING_TYPES:
        return base
    parts = base.split('/')
    if len(parts) == 1:
        if base in _ROS1_ALIASES:
            return _ROS1_ALIASES[base]
        return f'{package}/msg/{base}'
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    if parts[1] != 'msg':
        return None
    return base


def _parse_type(src: _Source, line: _Line, column: int, token: str, package: str) -> FieldType:
    match = _TYPE.match(token)
    if not match:
        raise src.error(line, column, f'expected a field type, found {token!r}')
    base = _resolve_base(match['base'], package)
    if base is None:
        raise src.error(line, column, f'expected "pkg/msg/Name" or "pkg/Name", found {token!r}')
    string_bound = 0
    if match['sbound'] is not None:
        if base not in STRING_TYPES:
            raise src.error(line, column, f'only string and wstring take a bound "<=N": {token!r}')
        string_bound = int(match['sbound'])
        if string_bound <= 0:
            raise src.error(line, column, 'a string bound must be greater than 0')
    shape = match['shape']
    if shape is None:
        return FieldType(base, Kind.SCALAR, 0, string_bound)
    if shape == '':
        return FieldType(base, Kind.SEQUENCE, 0, string_bound)
    bounded = shape.startswith('<=')
    digits = shape[2:] if bounded else shape
    if not digits.isdigit() or int(digits) <= 0:
        problem = 'expected an array size "[N]", bound "[<=N]" or "[]" with N > 0'
        raise src.error(line, column + token.index('['), problem)
    return FieldType(base, Kind.BOUNDED if bounded else Kind.ARRAY, int(digits), string_bound)


def _unquote(src: _Source, line: _Line, column: int, text: str) -> str:
    if len(text) >= 2 and text[0] in '"\'' and text[-1] == text[0]:
        quote = text[0]
        inner = text[1:-1]
        if re.search(rf'(?<!\\){quote}', inner):
            raise src.error(line, column, f'unescaped {quote} inside a quoted string')
        return inner.replace('\\' + quote, quote)
    return text


def _parse_scalar(src: _Source, line: _Line, column: int, ftype: FieldType, text: str) -> Value:
    base = ftype.base
    if base == 'bool':
        lowered = text.lower()
        if lowered in ('true', '1'):
            return True
        if lowered in ('false', '0'):
            return False
        raise src.error(line, column, f'expected true, false, 1 or 0 for a bool, found {text!r}')
    if base in INTEGER_RANGES:
        low, high = INTEGER_RANGES[base]
        try:
            number = int(text, 0)
        except ValueError:
            try:
                number = int(text)
            except ValueError:
                raise src.error(line, column, f'expected an integer, found {text!r}') from None
        if not low <= number <= high:
            raise src.error(line, column, f'{number} is out of the range of {base} [{low}, {high}]')
        return number
    if base in ('float32', 'float64'):
        try:
            return float(text)
        except ValueError:
            raise src.error(
                line, column, f'expected a floating point number, found {text!r}'
            ) from None
    value = _unquote(src, line, column, text)
    if ftype.string_bound and len(value) > ftype.string_bound:
        raise src.error(line, column, f'string longer than its bound {ftype.string_bound}')
    return value


def _split_string_list(src: _Source, line: _Line, column: int, text: str) -> list[str]:
    """Split the inside of ``[...]`` for string arrays, where commas may sit inside quotes."""
    items: list[str] = []
    rest = text.strip()
    while rest:
        if rest[0] in '"\'':
            quote = rest[0]
            index = 1
            while index < len(rest) and not (rest[index] == quote and rest[index - 1] != '\\'):
                index += 1
            if index >= len(rest):
                raise src.error(line, column, 'unterminated quoted string in array default')
            items.append(rest[: index + 1])
            rest = rest[index + 1 :].lstrip()
        else:
            comma = rest.find(',')
            items.append(rest if comma < 0 else rest[:comma].rstrip())
            rest = '' if comma < 0 else rest[comma:]
        if rest:
            if rest[0] != ',':
                raise src.error(line, column, 'expected "," between array elements')
            rest = rest[1:].lstrip()
    return items


def _parse_default(
    src: _Source, line: _Line, column: int, ftype: FieldType, text: str
) -> DefaultValue:
    if ftype.is_nested:
        raise src.error(line, column, 'only primitive and string fields can have a default value')
    if ftype.is_scalar:
        return _parse_scalar(src, line, column, ftype, text)
    if not (text.startswith('[') and text.endswith(']')):
        raise src.error(line, column, 'an array default must be written "[a, b, ...]"')
    inner = text[1:-1]
    if ftype.is_string:
        items = _split_string_list(src, line, column, inner)
    else:
        items = [item.strip() for item in inner.split(',')] if inner.strip() else []
    if ftype.kind is Kind.ARRAY and len(items) != ftype.length:
        raise src.error(
            line, column, f'expected exactly {ftype.length} elements, found {len(items)}'
        )
    if ftype.kind is Kind.BOUNDED and len(items) > ftype.length:
        raise src.error(
            line, column, f'expected at most {ftype.length} elements, found {len(items)}'
        )
    element = ftype.element
    return tuple(_parse_scalar(src, line, column, element, item) for item in items)


def _parse_lines(src: _Source, name: str, lines: list[_Line]) -> MessageDef:
    package = name.split('/', maxsplit=1)[0]
    fields: list[Field] = []
    constants: list[Constant] = []
    names: set[str] = set()
    for line in lines:
        text = line.text
        if not text.strip():
            continue
        indent = len(text) - len(text.lstrip())
        type_token, _, rest = text.strip().partition(' ')
        ftype = _parse_type(src, line, indent + 1, type_token, package)
        stripped = rest.lstrip()
        # 1-based column of the name (just past the type when the name is missing)
        column = indent + len(type_token) + 1 + (len(rest) - len(stripped)) + (1 if rest else 0)
        match = _IDENT.match(stripped)
        if not match:
            found = stripped.split(' ')[0] if stripped else 'end of line'
            raise src.error(line, column, f'expected a field or constant name, found {found!r}')
        field_name = match.group()
        after = stripped[match.end() :]
        after_stripped = after.lstrip()
        value_column = column + match.end() + (len(after) - len(after_stripped))
        if field_name in names:
            raise src.error(line, column, f'duplicate name {field_name!r}')
        names.add(field_name)
        if after_stripped.startswith('='):
            if not ftype.is_scalar or ftype.is_nested:
                raise src.error(
                    line, indent + 1, 'a constant must have a primitive or string scalar type'
                )
            value_text = after_stripped[1:].strip()
            if not value_text:
                raise src.error(line, value_column + 1, 'expected a constant value after "="')
            value = _parse_scalar(src, line, value_column + 1, ftype, value_text)
            constants.append(Constant(field_name, ftype, value))
            continue
        if after and not after[0].isspace():
            raise src.error(
                line, column + match.end(), f'unexpected character {after[0]!r} in a field name'
            )
        default = None
        if after_stripped:
            default = _parse_default(src, line, value_column, ftype, after_stripped)
        fields.append(Field(field_name, ftype, default))
    return MessageDef(name, tuple(fields), tuple(constants), src.origin)


def _split_sections(src: _Source, lines: list[_Line], count: int, what: str) -> list[list[_Line]]:
    sections: list[list[_Line]] = [[]]
    for line in lines:
        if _SEPARATOR.match(line.text):
            sections.append([])
        else:
            sections[-1].append(line)
    if len(sections) != count:
        last = lines[-1] if lines else _Line(1, '', '')
        raise src.error(
            last,
            1,
            f'a {what} needs exactly {count - 1} "---" separator line(s), '
            f'found {len(sections) - 1}',
        )
    return sections


def parse_message(name: str, text: str, origin: str = '<string>') -> MessageDef:
    """Parse .msg text of the message ``pkg/msg/Name``."""
    split_type_name(name)
    src = _Source(origin)
    return replace(_parse_lines(src, name, _lines(text)), source=text)


def parse_service(name: str, text: str, origin: str = '<string>') -> ServiceDef:
    """Parse .srv text of the service ``pkg/srv/Name``."""
    split_type_name(name)
    src = _Source(origin)
    request, response = _split_sections(src, _lines(text), 2, 'service')
    return ServiceDef(
        name,
        _parse_lines(src, name + '_Request', request),
        _parse_lines(src, name + '_Response', response),
        origin,
        text,
    )


def parse_action(name: str, text: str, origin: str = '<string>') -> ActionDef:
    """Parse .action text of the action ``pkg/action/Name``."""
    split_type_name(name)
    src = _Source(origin)
    goal, result, feedback = _split_sections(src, _lines(text), 3, 'action')
    return ActionDef(
        name,
        _parse_lines(src, name + '_Goal', goal),
        _parse_lines(src, name + '_Result', result),
        _parse_lines(src, name + '_Feedback', feedback),
        origin,
        text,
    )


def parse_definition(name: str, text: str, origin: str = '<string>') -> Definition:
    """Parse interface text, choosing the grammar from the kind in ``name``."""
    kind = split_type_name(name)[1]
    if kind == 'srv':
        return parse_service(name, text, origin)
    if kind == 'action':
        return parse_action(name, text, origin)
    return parse_message(name, text, origin)


def parse_message_bundle(name: str, text: str, origin: str = '<string>') -> list[MessageDef]:
    """Parse a definition with its dependencies appended, as stored in bags.

    The format is the main message's text, then for each dependency a line of ``=`` characters,
    a line ``MSG: pkg/Name`` (or ``pkg/msg/Name``) and that message's text. Returns the main
    message first.
    """
    src = _Source(origin)
    sections: list[tuple[str, list[_Line]]] = [(name, [])]
    lines = _lines(text)
    index = 0
    while index < len(lines):
        line = lines[index]
        if _BUNDLE_RULE.match(line.raw):
            header = lines[index + 1] if index + 1 < len(lines) else None
            match = _BUNDLE_HEADER.match(header.raw.strip()) if header else None
            if header is None or match is None:
                raise src.error(header or line, 1, 'expected "MSG: pkg/Name" after a "===" line')
            sub = match.group(1)
            full = _resolve_base(sub, name.split('/', maxsplit=1)[0]) if '/' in sub else None
            if full is None:
                raise src.error(header, 6, f'expected a message name "pkg/Name", found {sub!r}')
            sections.append((full, []))
            index += 2
            continue
        sections[-1][1].append(line)
        index += 1
    return [
        replace(_parse_lines(src, section_name, body), source=''.join(f'{x.raw}\n' for x in body))
        for section_name, body in sections
    ]
