"""Messages as text the way the ros2 command prints them: YAML (``ros2 topic echo``) and CSV.

The YAML is what PyYAML's default dumper writes for rosidl's ordered dictionaries, reproduced
with ruamel.yaml (a zros dependency): block style, fields in definition order, floats as
``1.0e-05``, ambiguous strings quoted.
"""

from __future__ import annotations

import io
import itertools
import math
import operator
import sys
from collections.abc import Collection, Iterable, Sized
from typing import TYPE_CHECKING, SupportsIndex, cast

from zros.cdr.message import Message, definition_of
from zros.cdr.model import FieldType, Kind

if TYPE_CHECKING:
    import re
    from typing import TypeAlias

    from ruamel.yaml import YAML
    from ruamel.yaml.nodes import Node
    from ruamel.yaml.representer import SafeRepresenter


#: a message as plain data (``to_plain``): what the YAML and CSV writers take
PlainValue: TypeAlias = (
    bool | int | float | str | list['PlainValue'] | dict[str, 'PlainValue'] | None
)

#: IDL names rosidl gives the .msg primitives (what ``--no-arr`` prints)
_PRIMITIVE_NAMES = {
    'byte': 'octet',
    'char': 'uint8',
    'bool': 'boolean',
    'float32': 'float',
    'float64': 'double',
}


def _type_name(field_type: FieldType) -> str:
    element = field_type.element
    if element.is_nested:
        return element.base
    return _PRIMITIVE_NAMES.get(element.base, element.base)


def _abbreviate(value: Sized, field_type: FieldType) -> str:
    name = _type_name(field_type)
    if field_type.kind is Kind.ARRAY:
        return f'<array type: {name}[{field_type.length}]>'
    if field_type.kind is Kind.BOUNDED:
        return f'<sequence type: {name}[{field_type.length}], length: {len(value)}>'
    return f'<sequence type: {name}, length: {len(value)}>'


def _byte_text(value: object, csv: bool) -> str:
    """rclpy holds ``byte`` values as ``bytes``: ros2 prints them as characters in YAML and as
    ``b'\\xff'`` in CSV."""
    if isinstance(value, bytes):
        data = value
    elif hasattr(value, '__index__'):  # an int or a numpy integer (no numpy import per item)
        data = bytes([operator.index(cast('SupportsIndex', value))])
    else:
        raise TypeError(f'a byte field holds {type(value).__name__}')
    return repr(data) if csv else ''.join(chr(c) for c in data)


def _cut(value: Collection[object], truncate: int | None) -> tuple[list[object], bool]:
    """The first ``truncate`` items of a sequence as a list (all when ``None``), and whether
    some were left off; only those kept are converted (a camera image has millions)."""
    import numpy as np

    if truncate is None or len(value) <= truncate:
        return (value.tolist() if isinstance(value, np.ndarray) else list(value)), False
    if isinstance(value, np.ndarray):
        return value[:truncate].tolist(), True
    return list(itertools.islice(value, truncate)), True


def _plain(
    value: object,
    field_type: FieldType | None,
    options: tuple[int | None, bool, bool, bool],
) -> PlainValue:
    import numpy as np

    truncate, no_arr, no_str, csv = options
    is_byte = field_type is not None and field_type.element.base == 'byte'
    if field_type is not None and not field_type.is_scalar:
        if not isinstance(value, Collection):
            raise TypeError(f'an array field holds {type(value).__name__}')
        if no_arr:
            return _abbreviate(value, field_type)
        items, cut = _cut(value, truncate)
        converted = [
            _byte_text(item, csv) if is_byte else _plain(item, field_type.element, options)
            for item in items
        ]
        return [*converted, '...'] if cut else converted
    if is_byte:
        return _byte_text(value, csv)
    if isinstance(value, str):
        if no_str:
            return f'<string length: <{len(value)}>>'
        if truncate is not None and len(value) > truncate:
            return value[:truncate] + '...'
        return value
    if isinstance(value, np.generic):
        item: PlainValue = value.item()
        return item
    if isinstance(value, Message):
        return _fields(value, options)
    if isinstance(value, (bytes, bytearray, np.ndarray, list, tuple)):  # a --field selection
        items, cut = _cut(value, truncate)
        converted = [_plain(element, None, options) for element in items]
        return [*converted, '...'] if cut else converted
    return cast('PlainValue', value)  # a bool, int, float (or None) field


def _fields(
    message: Message, options: tuple[int | None, bool, bool, bool]
) -> dict[str, PlainValue]:
    return {
        field.name: _plain(getattr(message, field.name), field.type, options)
        for field in definition_of(type(message)).fields
    }


def to_plain(
    message: Message,
    *,
    truncate: int | None = None,
    no_arr: bool = False,
    no_str: bool = False,
    csv: bool = False,
) -> dict[str, PlainValue]:
    """A message as nested dicts and lists, fields in definition order, values as ros2 shows
    them (``csv`` for the forms of ``--csv``)."""
    return _fields(message, (truncate, no_arr, no_str, csv))


#: PyYAML's implicit tags (YAML 1.1 as PyYAML reads it), with the first characters that select
#: them: a string looking like one is quoted by ros2 (``'yes'``, ``'123'``, ``'2001-12-14'``);
#: ruamel's own 1.1 and 1.2 rules differ a little (``y``, ``1e5``...)
_IMPLICIT = (
    (
        'bool',
        r'yes|Yes|YES|no|No|NO|true|True|TRUE|false|False|FALSE|on|On|ON|off|Off|OFF',
        'yYnNtTfFoO',
    ),
    (
        'float',
        r'[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+][0-9]+)?|\.[0-9][0-9_]*(?:[eE][-+][0-9]+)?'
        r'|[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)',
        '-+0123456789.',
    ),
    (
        'int',
        r'[-+]?0b[0-1_]+|[-+]?0[0-7_]+|[-+]?(?:0|[1-9][0-9_]*)|[-+]?0x[0-9a-fA-F_]+'
        r'|[-+]?[1-9][0-9_]*(?::[0-5]?[0-9])+',
        '-+0123456789',
    ),
    ('merge', r'<<', '<'),
    ('null', r'~|null|Null|NULL|', '~nN'),
    (
        'timestamp',
        r'[0-9]{4}-[0-9]{2}-[0-9]{2}|[0-9]{4}-[0-9]{1,2}-[0-9]{1,2}(?:[Tt]|[ \t]+)[0-9]{1,2}'
        r':[0-9]{2}:[0-9]{2}(?:\.[0-9]*)?(?:[ \t]*(?:Z|[-+][0-9]{1,2}(?::[0-9]{2})?))?',
        '0123456789',
    ),
    ('value', r'=', '='),
    ('yaml', r'!|&|\*', '!&*'),
)


def _resolver() -> type:
    import re

    from ruamel.yaml.resolver import VersionedResolver

    table: dict[str, list[tuple[str, re.Pattern[str]]]] = {
        '': [('tag:yaml.org,2002:null', re.compile(''))]
    }
    for tag, pattern, first in _IMPLICIT:
        regexp = re.compile(f'^(?:{pattern})$')
        for char in first:
            table.setdefault(char, []).append((f'tag:yaml.org,2002:{tag}', regexp))

    class PyYamlResolver(VersionedResolver):
        @property
        def versioned_resolver(self) -> dict[str, list[tuple[str, re.Pattern[str]]]]:
            return {char: list(rules) for char, rules in table.items()}

    return PyYamlResolver


def _dumper(flow_style: bool) -> YAML:
    from ruamel.yaml import YAML

    yaml = YAML(typ='safe', pure=True)
    yaml.Resolver = _resolver()
    yaml.default_flow_style = False
    yaml.width = sys.maxsize
    yaml.allow_unicode = True

    def represent_float(representer: SafeRepresenter, value: float) -> Node:
        if math.isnan(value):
            text = '.nan'
        elif math.isinf(value):
            text = '.inf' if value > 0 else '-.inf'
        else:
            text = repr(value).lower()
            if '.' not in text and 'e' in text:
                text = text.replace('e', '.0e', 1)
        return representer.represent_scalar('tag:yaml.org,2002:float', text)

    def represent_dict(
        representer: SafeRepresenter, value: dict[str, PlainValue]
    ) -> Node:  # in order
        return representer.represent_mapping('tag:yaml.org,2002:map', list(value.items()))

    def represent_list(representer: SafeRepresenter, value: list[PlainValue]) -> Node:
        # ros2's --flow-style makes sequences flow and leaves messages in block style
        return representer.represent_sequence('tag:yaml.org,2002:seq', value, flow_style=flow_style)

    def represent_str(representer: SafeRepresenter, value: str) -> Node:
        if '\n' in value and all(c == '\n' or c.isprintable() for c in value):
            # PyYAML single-quotes multi-line text where ruamel would double-quote it
            return representer.represent_scalar('tag:yaml.org,2002:str', value, style="'")
        node: Node = representer.represent_str(value)  # annotated Any in ruamel.yaml
        return node

    yaml.representer.add_representer(str, represent_str)
    yaml.representer.add_representer(float, represent_float)
    yaml.representer.add_representer(dict, represent_dict)
    yaml.representer.add_representer(list, represent_list)
    return yaml


def to_yaml(value: PlainValue, flow_style: bool = False) -> str:
    """YAML text of plain data (``to_plain``'s result) as ros2 prints it."""
    buffer = io.StringIO()
    _dumper(flow_style).dump(value, buffer)
    return buffer.getvalue()


def message_to_yaml(
    message: Message,
    *,
    truncate: int | None = None,
    no_arr: bool = False,
    no_str: bool = False,
    flow_style: bool = False,
) -> str:
    """A message as ``ros2 topic echo`` prints it (without the ``---`` line)."""
    return to_yaml(to_plain(message, truncate=truncate, no_arr=no_arr, no_str=no_str), flow_style)


def value_to_yaml(
    value: object,
    *,
    truncate: int | None = None,
    no_arr: bool = False,
    no_str: bool = False,
    flow_style: bool = False,
) -> str:
    """A field's value (``--field``) as YAML; scalars without the ``...`` end marker."""
    text = to_yaml(_plain(value, None, (truncate, no_arr, no_str, False)), flow_style)
    return text[: -len('...\n')] if text.endswith('\n...\n') else text


def message_to_csv(
    message: Message, *, truncate: int | None = None, no_arr: bool = False, no_str: bool = False
) -> str:
    """A message as ``ros2 topic echo --csv`` prints it: leaf values, comma separated."""

    def join(items: Iterable[PlainValue]) -> str:
        # ros2 adds a comma only after non-empty text: a leading '' element leaves no trace
        result = ''
        for item in items:
            if result:
                result += ','
            result += text(item)
        return result

    def text(value: PlainValue) -> str:
        if isinstance(value, dict):
            return join(value.values())
        if isinstance(value, list):
            return join(value)
        return str(value)

    return text(to_plain(message, truncate=truncate, no_arr=no_arr, no_str=no_str, csv=True))


def select(message: Message, path: str) -> object:
    """The value at a dotted path (``pose.position``), for ``--field``."""
    from zros.cdr.errors import FieldError

    value: object = message
    parts = [part for part in path.split('.') if part]
    for index, part in enumerate(parts):
        if not isinstance(value, Message):
            raise KeyError(f"--field {path}: '{part}' is not a field of {type(value).__name__}")
        if part not in value.__slots__:
            names = tuple(field.name for field in definition_of(type(value)).fields)
            error = FieldError.unknown(value.__msgtype__, part, names)  # "did you mean"
            if index:
                error = error.inside(message.__msgtype__, '.'.join(parts[:index]))
            raise KeyError(f'--field {path}: {error}')
        value = getattr(value, part)
    return value
