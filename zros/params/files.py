"""ROS 2 parameter files and command-line values, read and written as ROS 2 does.

A file maps node names to ``ros__parameters``::

    /robot/driver:          # or nested: robot: {driver: {ros__parameters: ...}}
      ros__parameters:
        speed: 0.5
        wheels: {left: 1, right: 2}   # names wheels.left and wheels.right
    /**:                    # every node; * is one name token, ** any number of them
      ros__parameters:
        use_sim_time: true

Scalars are typed like rcl types them (not like YAML 1.2): unquoted ``true``/``yes``/``on``/``y``
and their opposites are booleans, what C's ``strtol`` reads whole is an integer (``0x1f``,
``010`` is octal), what ``strtod`` reads whole is a double (``1e3``, ``.inf``), anything else
and anything quoted is a string. A list holds one type. ``!!binary`` is a byte array.
"""

from __future__ import annotations

import base64
import json
import math
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from zros.params.errors import ParameterError
from zros.params.values import ParameterType, ParamValue, infer_type, normalize

if TYPE_CHECKING:
    from ruamel.yaml import YAML
    from ruamel.yaml.nodes import MappingNode, Node

PARAMETERS_KEY = 'ros__parameters'

_TRUE = {'Y', 'y', 'yes', 'Yes', 'YES', 'true', 'True', 'TRUE', 'on', 'On', 'ON'}
_FALSE = {'N', 'n', 'no', 'No', 'NO', 'false', 'False', 'FALSE', 'off', 'Off', 'OFF'}
_INTEGER = re.compile(r'[+-]?(?:0[xX][0-9a-fA-F]+|0[0-7]*|[1-9][0-9]*)')
_DECIMAL = re.compile(r'[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?')
_HEX_FLOAT = re.compile(
    r'[+-]?0[xX](?:[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)(?:[pP][+-]?[0-9]+)?'
)
_SPECIAL = re.compile(r'[+-]?(?:inf|infinity|nan)', re.IGNORECASE)
_YAML_SPECIAL = re.compile(r'[+-]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)')


#: the (node pattern, values) entries of a parameter file, in file order
Entries = list[tuple[str, dict[str, ParamValue]]]


def scalar(text: str, quoted: bool) -> ParamValue:
    """The value of one YAML scalar, typed as rcl types parameter values."""
    if quoted:
        return text
    if text in _TRUE:
        return True
    if text in _FALSE:
        return False
    if _INTEGER.fullmatch(text):
        sign = -1 if text.startswith('-') else 1
        digits = text.lstrip('+-')
        if digits[:2] in ('0x', '0X'):
            number = int(digits, 16)
        elif digits.startswith('0') and len(digits) > 1:
            number = int(digits, 8)
        else:
            number = int(digits)
        number *= sign
        if -(2**63) <= number < 2**63:
            return number
        return float(number)  # strtol overflows; strtod reads it
    if _YAML_SPECIAL.fullmatch(text):
        value = math.nan if 'nan' in text.lower() else math.inf
        return -value if text.startswith('-') else value
    if _DECIMAL.fullmatch(text) or _SPECIAL.fullmatch(text):
        return float(text)
    if _HEX_FLOAT.fullmatch(text):
        return float.fromhex(text)
    return text


def _yaml() -> YAML:
    from ruamel.yaml import YAML  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    return YAML(typ='safe', pure=True)


def _where(origin: str, node: Node) -> str:
    mark = getattr(node, 'start_mark', None)
    return f'{origin}:{mark.line + 1}' if mark is not None else origin


def _value(node: Node, origin: str, key: Node | None = None) -> ParamValue:
    from ruamel.yaml.nodes import MappingNode, ScalarNode, SequenceNode  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    if isinstance(node, ScalarNode):
        if node.tag == 'tag:yaml.org,2002:binary':
            try:
                return base64.b64decode(''.join(node.value.split()), validate=True)
            except ValueError:
                raise ParameterError(f'{_where(origin, node)}: bad !!binary data') from None
        quoted = node.style in ("'", '"', '|', '>')
        if not quoted and node.value == '':
            raise ParameterError(f'{_where(origin, key or node)}: no value')
        return scalar(node.value, quoted)
    if isinstance(node, SequenceNode):
        items: list[ParamValue] = []
        for item in node.value:
            if not isinstance(item, ScalarNode):
                raise ParameterError(f'{_where(origin, item)}: a parameter list holds scalars only')
            items.append(_value(item, origin))
        try:  # the check; empty lists stay untyped
            kind = infer_type(items, ParameterType.STRING_ARRAY)
        except ParameterError as exc:
            raise ParameterError(f'{_where(origin, node)}: {exc}') from None
        return normalize(items, kind) if items else []
    if isinstance(node, MappingNode):
        raise ParameterError(f'{_where(origin, node)}: a mapping is not a value')
    raise ParameterError(f'{_where(origin, node)}: unreadable value')


def _flatten(node: MappingNode, prefix: str, origin: str, into: dict[str, ParamValue]) -> None:
    from ruamel.yaml.nodes import MappingNode  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    for key_node, value_node in node.value:
        name = f'{prefix}{key_node.value}'
        if isinstance(value_node, MappingNode):
            _flatten(value_node, name + '.', origin, into)
        else:
            into[name] = _value(value_node, origin, key_node)


def _walk(node: Node, path: str, origin: str, found: Entries) -> None:
    from ruamel.yaml.nodes import MappingNode  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    if not isinstance(node, MappingNode):
        raise ParameterError(f'{_where(origin, node)}: expected node names mapping to '
                             f'{PARAMETERS_KEY}')  # fmt: skip
    for key_node, value_node in node.value:
        key = str(key_node.value)
        if key == PARAMETERS_KEY:
            if not path:
                raise ParameterError(f'{_where(origin, key_node)}: {PARAMETERS_KEY} needs a node')
            if not isinstance(value_node, MappingNode):
                raise ParameterError(f'{_where(origin, value_node)}: expected name: value pairs')
            values: dict[str, ParamValue] = {}
            _flatten(value_node, '', origin, values)
            found.append((path, values))
        else:
            _walk(value_node, f'{path}/{key.strip("/")}', origin, found)


def parse_file_text(text: str, origin: str = '<parameters>') -> Entries:
    """The (node pattern, parameters) entries of a parameter file, in file order."""
    from ruamel.yaml.error import YAMLError  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    try:
        root = _yaml().compose(text)
    except YAMLError as exc:
        raise ParameterError(f'{origin}: not valid YAML: {exc}') from None
    found: Entries = []
    if root is not None:
        _walk(root, '', origin, found)
    return found


def load_file(path: str | os.PathLike[str]) -> Entries:
    """The (node pattern, parameters) entries of a parameter file, in file order."""
    file = Path(path)
    try:
        text = file.read_text()
    except OSError as exc:
        raise ParameterError(f'cannot read the parameter file {file}: {exc.strerror}') from None
    return parse_file_text(text, str(file))


def node_matches(pattern: str, node_fqn: str) -> bool:
    """Whether a file's node name (``/ns/node``, ``node``, ``/**``, ``/*/node``...) names a node."""
    wanted = [token for token in pattern.split('/') if token]
    tokens = [token for token in node_fqn.split('/') if token]

    def match(i: int, j: int) -> bool:
        if i == len(wanted):
            return j == len(tokens)
        if wanted[i] == '**':
            return any(match(i + 1, k) for k in range(j, len(tokens) + 1))
        if j == len(tokens):
            return False
        return (wanted[i] == '*' or wanted[i] == tokens[j]) and match(i + 1, j + 1)

    return match(0, 0)


def values_for(entries: Entries, node_fqn: str) -> dict[str, ParamValue]:
    """The values the entries give one node, later entries overriding earlier ones."""
    result: dict[str, ParamValue] = {}
    for pattern, values in entries:
        if node_matches(pattern, node_fqn):
            result.update(values)
    return result


def parse_override(text: str) -> tuple[str, ParamValue]:
    """A ``-p name:=value`` command-line override (the value is YAML, typed as in files)."""
    name, separator, value = text.partition(':=')
    if not separator or not name:
        raise ParameterError(f'-p takes name:=value, not {text!r}')
    from ruamel.yaml.error import YAMLError  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    try:
        node = _yaml().compose(value if value.strip() else "''")
    except YAMLError as exc:
        raise ParameterError(f'-p {text}: the value is not valid YAML: {exc}') from None
    return name, _value(node, f'-p {name}')


# ``ros2 param set`` reads its value with PyYAML (YAML 1.1), not with rcl's rules: only these
# spellings are booleans (``y`` is a string), a float needs a dot (``1e3`` is a string)
_SET_TRUE = {'yes', 'Yes', 'YES', 'true', 'True', 'TRUE', 'on', 'On', 'ON'}
_SET_FALSE = {'no', 'No', 'NO', 'false', 'False', 'FALSE', 'off', 'Off', 'OFF'}
_SET_NULL = {'', '~', 'null', 'Null', 'NULL'}
_SET_INTEGER = re.compile(
    r'[-+]?(?:0b[01_]+|0x[0-9a-fA-F_]+|0[0-7_]+|0|[1-9][0-9_]*(?::[0-5]?[0-9])*)'
)
_SET_FLOAT = re.compile(
    r'[-+]?[0-9][0-9_]*\.[0-9_]*(?:[eE][-+][0-9]+)?|\.[0-9_]+(?:[eE][-+][0-9]+)?'
    r'|[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*'
)
_NOT_A_VALUE = object()  # null, a mapping, a date...: what no parameter type holds


def _sexagesimal(text: str, number: type[int] | type[float]) -> int | float:
    total: int | float = 0
    for part in text.split(':'):
        total = total * 60 + number(part)
    return total


def _set_scalar(text: str, quoted: bool) -> object:
    if quoted:
        return text
    if text in _SET_TRUE or text in _SET_FALSE:
        return text in _SET_TRUE
    if text in _SET_NULL:
        return _NOT_A_VALUE
    sign = -1 if text.startswith('-') else 1
    digits = text.lstrip('+-').replace('_', '')
    if _SET_INTEGER.fullmatch(text):
        if ':' in digits:
            return sign * _sexagesimal(digits, int)
        base = {'0b': 2, '0x': 16}.get(digits[:2], 8 if digits[:1] == '0' and digits != '0' else 10)
        return sign * int(digits[2:] if base in (2, 16) else digits, base)
    if _SET_FLOAT.fullmatch(text):
        return sign * (_sexagesimal(digits, float) if ':' in digits else float(digits))
    if _YAML_SPECIAL.fullmatch(text):
        return scalar(text, quoted=False)
    return text


def set_value(text: str) -> ParamValue:
    """A ``param set`` value, typed as ``ros2 param set`` types it: YAML 1.1 scalars (``y`` and
    ``1e3`` are strings), a list of one type is an array (``[]`` an empty one, whose type the
    parameter decides), and anything else (a mixed list, a mapping, text YAML cannot read) is
    the text itself as a string."""
    from ruamel.yaml.error import YAMLError  # noqa: PLC0415 (lazy: ruamel.yaml, import time)
    from ruamel.yaml.nodes import ScalarNode, SequenceNode  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    try:
        node = _yaml().compose(text)
    except YAMLError:
        return text

    def read(item: object) -> object:
        if isinstance(item, ScalarNode) and item.tag != 'tag:yaml.org,2002:binary':
            return _set_scalar(item.value, quoted=item.style in ("'", '"', '|', '>'))
        return _NOT_A_VALUE

    if isinstance(node, SequenceNode):
        items = [read(item) for item in node.value]
        for kind, array in (
            (bool, ParameterType.BOOL_ARRAY),
            (int, ParameterType.INTEGER_ARRAY),  # a bool is an int, as in Python
            (float, ParameterType.DOUBLE_ARRAY),
            (str, ParameterType.STRING_ARRAY),
        ):
            if all(isinstance(item, kind) for item in items):
                return normalize(items, array)
        return text
    value = read(node) if node is not None else _NOT_A_VALUE
    return value if isinstance(value, (bool, int, float, str)) else text


# --- writing -----------------------------------------------------------------------------------


def _format_scalar(value: ParamValue) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return '.nan'
        if math.isinf(value):
            return '.inf' if value > 0 else '-.inf'
        return repr(value)
    return json.dumps(str(value), ensure_ascii=False)  # a JSON string is a YAML double-quoted one


def _format(value: ParamValue) -> str:
    if isinstance(value, (bytes, bytearray)):
        return f'!!binary {base64.b64encode(bytes(value)).decode()}'
    if isinstance(value, list):
        return '[' + ', '.join(_format_scalar(item) for item in value) + ']'
    return _format_scalar(value)


#: parameters nested by the dots of their names
_Tree = dict[str, 'ParamValue | _Tree']


def _nest(values: dict[str, ParamValue]) -> _Tree:
    tree: _Tree = {}
    for name, value in sorted(values.items()):
        parts = name.split('.')
        level = tree
        for part in parts[:-1]:
            child = level.setdefault(part, {})
            if not isinstance(child, dict):  # 'a' and 'a.b' both set: keep the dotted name whole
                level = tree
                parts = [name]
                break
            level = child
        level[parts[-1]] = value
    return tree


def dump(node_fqn: str, values: dict[str, ParamValue]) -> str:
    """The parameters of one node as a ROS 2 parameter file (``ros2 param dump`` layout)."""
    lines = [f'{node_fqn}:', f'  {PARAMETERS_KEY}:']

    def emit(tree: _Tree, indent: int) -> None:
        for key, value in tree.items():
            if isinstance(value, dict):
                lines.append(f'{" " * indent}{key}:')
                emit(value, indent + 2)
            elif value is not None:
                lines.append(f'{" " * indent}{key}: {_format(value)}')

    emit(_nest(values), 4)
    return '\n'.join(lines) + '\n'
