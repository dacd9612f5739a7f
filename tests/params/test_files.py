"""ROS 2 parameter files and -p values, typed as rcl types them; dumps load back."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from zros.params import ParameterError, dump, load_file, parse_file_text, parse_override
from zros.params.files import node_matches, scalar, values_for


@pytest.mark.parametrize(
    ('text', 'expected'),
    [
        ('true', True), ('Yes', True), ('ON', True), ('y', True),
        ('false', False), ('no', False), ('Off', False), ('N', False),
        ('42', 42), ('-7', -7), ('+3', 3), ('0x1f', 31), ('010', 8), ('0', 0),
        ('9223372036854775807', 2**63 - 1),
        ('9223372036854775808', 9223372036854775808.0),  # beyond int64: strtod reads it
        ('1.5', 1.5), ('1e3', 1000.0), ('-.5', -0.5), ('09', 9.0), ('1.', 1.0),
        ('.inf', math.inf), ('-.Inf', -math.inf), ('inf', math.inf), ('0x1p3', 8.0),
        ('hello', 'hello'), ('1_000', '1_000'), ('0b101', '0b101'), ('null', 'null'),
        ('1.2.3', '1.2.3'), ('--1', '--1'),
    ],
)  # fmt: skip
def test_unquoted_scalars_are_typed_like_rcl(text: str, expected: Any) -> None:
    value = scalar(text, quoted=False)
    assert type(value) is type(expected) and value == expected


def test_nan_and_quoted_scalars() -> None:
    assert math.isnan(scalar('.nan', quoted=False)) and math.isnan(scalar('NaN', quoted=False))
    for text in ('true', '42', '1.5', ''):
        assert scalar(text, quoted=True) == text


FILE = """\
/robot/driver:
  ros__parameters:
    speed: 0.5
    enabled: yes
    name: "driver one"
    count: 3
    wheels:
      left: 1
      right: 2
    gains: [1.0, 2, 3.5]
    ids: [1, 2, 3]
    flags: [true, false]
    labels: [a, 'b c']
    blob: !!binary aGVsbG8=
/**:
  ros__parameters:
    use_sim_time: true
    speed: 0.1
robot:
  "*":
    ros__parameters:
      everywhere_in_robot: 1
"""


def test_a_file_with_every_type_and_wildcards(tmp_path: Path) -> None:
    path = tmp_path / 'params.yaml'
    path.write_text(FILE)
    entries = load_file(path)
    assert [pattern for pattern, _ in entries] == ['/robot/driver', '/**', '/robot/*']
    values = values_for(entries, '/robot/driver')
    assert values == {
        'speed': 0.1,  # a later entry wins
        'enabled': True,
        'name': 'driver one',
        'count': 3,
        'wheels.left': 1,
        'wheels.right': 2,
        'gains': [1.0, 2, 3.5],
        'ids': [1, 2, 3],
        'flags': [True, False],
        'labels': ['a', 'b c'],
        'blob': b'hello',
        'use_sim_time': True,
        'everywhere_in_robot': 1,
    }
    assert values_for(entries, '/other') == {'use_sim_time': True, 'speed': 0.1}
    assert values_for(entries, '/robot/deep/node') == {'use_sim_time': True, 'speed': 0.1}


@pytest.mark.parametrize(
    ('pattern', 'name', 'matches'),
    [
        ('/node', '/node', True), ('node', '/node', True), ('/node', '/ns/node', False),
        ('/**', '/a/b/c', True), ('/**/c', '/a/b/c', True), ('/**/c', '/c', True),
        ('/*/c', '/a/c', True), ('/*/c', '/a/b/c', False), ('/a/**', '/a', True),
        ('/*', '/a/b', False),
    ],
)  # fmt: skip
def test_node_name_wildcards(pattern: str, name: str, matches: bool) -> None:
    assert node_matches(pattern, name) is matches


@pytest.mark.parametrize(
    ('text', 'message'),
    [
        ('/n:\n  ros__parameters:\n    a: [1, x]\n', 'one type, not integer and string'),
        ('/n:\n  ros__parameters:\n    a: [[1]]\n', 'scalars only'),
        ('/n:\n  ros__parameters:\n    a:\n', 'params.yaml:3: no value'),
        ('ros__parameters:\n  a: 1\n', 'needs a node'),
        ('/n:\n  ros__parameters: 5\n', 'expected name: value pairs'),
        ('/n: [1, 2]\n', 'expected node names'),
        ('/n:\n  ros__parameters:\n    a: {b: [\n', 'not valid YAML'),
        ('/n:\n  ros__parameters:\n    a: !!binary "%%%"\n', 'bad !!binary'),
    ],
)
def test_bad_files_name_the_place(text: str, message: str) -> None:
    with pytest.raises(ParameterError, match=message):
        parse_file_text(text, 'params.yaml')


def test_a_missing_file() -> None:
    with pytest.raises(ParameterError, match=r'cannot read the parameter file /no/such\.yaml'):
        load_file('/no/such.yaml')


def test_command_line_overrides() -> None:
    assert parse_override('speed:=0.5') == ('speed', 0.5)
    assert parse_override('ids:=[1, 2]') == ('ids', [1, 2])
    assert parse_override('name:=hello world') == ('name', 'hello world')
    assert parse_override("name:='42'") == ('name', '42')
    assert parse_override('flag:=on') == ('flag', True)
    assert parse_override('empty:=') == ('empty', '')
    with pytest.raises(ParameterError, match='-p takes name:=value'):
        parse_override('speed=0.5')


def test_a_dump_loads_back_to_the_same_values() -> None:
    values = {
        'bool': True,
        'int': -5,
        'big': 2**62,
        'double': 0.1,
        'whole_double': 3.0,
        'inf': math.inf,
        'string': 'hello',
        'tricky_strings': ['true', '42', 'a: b', "it's", 'line\nbreak', ''],
        'looks_numeric': '1e3',
        'bytes': b'\x00\xffzros',
        'bools': [True, False],
        'ints': [1, 2, 3],
        'doubles': [1.0, 2.5],
        'nested.deep.value': 7,
        'nested.other': 'x',
        'unicode': 'grüße',
    }
    text = dump('/robot/driver', values)
    assert text.startswith('/robot/driver:\n  ros__parameters:\n')
    back = values_for(parse_file_text(text), '/robot/driver')
    assert back == values
    assert all(type(back[k]) is type(v) for k, v in values.items())


@pytest.mark.parametrize(
    'text',
    ['y', 'n', 'yes', 'Off', '1e3', '1.0e3', '1.5e+3', '010', '0x1f', '-0x1f', '0b101', '1_000',
     '1:30', '1:30.5', '.inf', '-.Inf', '.nan', '-.5', '~', 'null', '', '2001-12-14', '[x, y]',
     '[]', '[1, 2.0]', '[true, 1]', '[.inf]', '{a: 1}', '"5"', 'a: b', '1.', '0o17', '+12',
     '0.5', '[1,', 'hello world'],
)  # fmt: skip
def test_set_value_types_as_ros2_param_set(text: str) -> None:
    """``ros2 param set`` types its value with PyYAML's ``safe_load``: the same type here."""
    yaml = pytest.importorskip('yaml')
    from zros.params.files import set_value

    try:
        loaded = yaml.safe_load(text)
    except yaml.YAMLError:
        loaded = text
    if isinstance(loaded, list):
        kinds = [k for k in (bool, int, float, str) if all(isinstance(v, k) for v in loaded)]
        expected = [kinds[0](v) for v in loaded] if kinds else text
    elif isinstance(loaded, (bool, int, float, str)):
        expected = loaded
    else:
        expected = text
    assert repr(set_value(text)) == repr(expected)
