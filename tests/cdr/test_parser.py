"""The .msg/.srv/.action parser: every construct, and errors that point at the problem."""

from __future__ import annotations

import pytest

from zros.cdr.errors import InterfaceSyntaxError, TypeNameError
from zros.cdr.model import Constant, Field, FieldType, Kind
from zros.cdr.parser import (
    parse_action,
    parse_definition,
    parse_message,
    parse_message_bundle,
    parse_service,
)

EVERY_FORM = """
# a comment line
bool flag   # trailing comment
byte b
char c
int8 i8
uint8 u8
int16 i16
uint16 u16
int32 i32
uint32 u32
int64 i64
uint64 u64
float32 f32
float64 f64
string s
wstring w
string<=5 bounded
float64[3] fixed
int32[<=4] bounded_seq
uint8[] unbounded
string<=3[2] bounded_strings
Point same_package
geometry_msgs/Pose short_other
geometry_msgs/msg/Twist full_other
Header header
time stamp
duration span
"""


def test_every_field_form() -> None:
    msg = parse_message('pkg/msg/All', EVERY_FORM)
    types = {f.name: f.type for f in msg.fields}
    assert types['flag'] == FieldType('bool')
    assert types['w'] == FieldType('wstring')
    assert types['bounded'] == FieldType('string', string_bound=5)
    assert types['fixed'] == FieldType('float64', Kind.ARRAY, 3)
    assert types['bounded_seq'] == FieldType('int32', Kind.BOUNDED, 4)
    assert types['unbounded'] == FieldType('uint8', Kind.SEQUENCE)
    assert types['bounded_strings'] == FieldType('string', Kind.ARRAY, 2, 3)
    assert types['same_package'] == FieldType('pkg/msg/Point')
    assert types['short_other'] == FieldType('geometry_msgs/msg/Pose')
    assert types['full_other'] == FieldType('geometry_msgs/msg/Twist')
    assert types['header'] == FieldType('std_msgs/msg/Header')
    assert types['stamp'] == FieldType('builtin_interfaces/msg/Time')
    assert types['span'] == FieldType('builtin_interfaces/msg/Duration')
    assert [f.name for f in msg.fields][:3] == ['flag', 'b', 'c']
    assert str(types['bounded_strings']) == 'string<=3[2]'


def test_constants_and_defaults() -> None:
    msg = parse_message(
        'pkg/msg/C',
        '\n'.join(
            [
                'int8 NEG=-5',
                'uint32 HEX=0x10',
                'bool YES=true',
                'float64 PI = 3.14',
                'string GREETING="hi # not a comment"',
                'string BARE=hello world',
                'int32 count 7',
                'bool on False',
                'float32 gain -1.5e3',
                "string quoted 'it''s'".replace("''", "\\'"),
                'string[] names ["a, b", \'c\', d]',
                'int16[3] triple [1, -2, 3]',
                'float64[<=2] pair [0.5]',
                'string plain free text',
            ]
        ),
    )
    constants = {c.name: c.value for c in msg.constants}
    assert constants == {
        'NEG': -5,
        'HEX': 16,
        'YES': True,
        'PI': 3.14,
        'GREETING': 'hi # not a comment',
        'BARE': 'hello world',
    }
    assert msg.constants[0] == Constant('NEG', FieldType('int8'), -5)
    defaults = {f.name: f.default for f in msg.fields}
    assert defaults == {
        'count': 7,
        'on': False,
        'gain': -1500.0,
        'quoted': "it's",
        'names': ('a, b', 'c', 'd'),
        'triple': (1, -2, 3),
        'pair': (0.5,),
        'plain': 'free text',
    }


def test_service_and_action_sections() -> None:
    srv = parse_service('pkg/srv/Add', 'int64 a\nint64 b\n---\nint64 sum\n')
    assert srv.request.name == 'pkg/srv/Add_Request'
    assert [f.name for f in srv.request.fields] == ['a', 'b']
    assert srv.response.fields == (Field('sum', FieldType('int64')),)
    empty = parse_service('pkg/srv/Nothing', '---')
    assert empty.request.fields == () and empty.response.fields == ()
    action = parse_action('pkg/action/Go', 'int32 order\n---\nint32[] seq\n---\nfloat32 progress')
    assert action.goal.name == 'pkg/action/Go_Goal'
    assert action.result.fields[0].type == FieldType('int32', Kind.SEQUENCE)
    assert action.feedback.fields[0].name == 'progress'
    assert parse_definition('pkg/action/Go', 'int32 a\n---\n---\n').name == 'pkg/action/Go'


def test_bundle_of_embedded_definitions() -> None:
    text = (
        'std_msgs/Header header\nPoint[] points\n'
        + '=' * 80
        + '\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n'
        + '=' * 80
        + '\nMSG: my_pkg/msg/Point\nfloat64 x\n'
    )
    messages = parse_message_bundle('my_pkg/msg/Cloud', text)
    assert [m.name for m in messages] == [
        'my_pkg/msg/Cloud',
        'std_msgs/msg/Header',
        'my_pkg/msg/Point',
    ]
    assert messages[0].fields[1].type == FieldType('my_pkg/msg/Point', Kind.SEQUENCE)


@pytest.mark.parametrize(
    ('text', 'line', 'column', 'problem'),
    [
        ('int32 ok\nint32 x y', 2, 9, 'expected an integer'),
        ('int32', 1, 6, "expected a field or constant name, found 'end of line'"),
        ('int32 1abc', 1, 7, "expected a field or constant name, found '1abc'"),
        ('int32 a\nint32 a', 2, 7, "duplicate name 'a'"),
        ('int8 x 200', 1, 8, '200 is out of the range of int8 [-128, 127]'),
        ('uint8 X=-1', 1, 9, '-1 is out of the range of uint8 [0, 255]'),
        ('bool b maybe', 1, 8, "expected true, false, 1 or 0 for a bool, found 'maybe'"),
        ('float64 f abc', 1, 11, "expected a floating point number, found 'abc'"),
        ('int32[0] a', 1, 6, 'expected an array size'),
        ('int32[x] a', 1, 6, 'expected an array size'),
        ('int32<=3 a', 1, 1, 'only string and wstring take a bound'),
        ('int32[2] a [1, 2, 3]', 1, 12, 'expected exactly 2 elements, found 3'),
        ('int32[<=1] a [1, 2]', 1, 14, 'expected at most 1 elements, found 2'),
        ('int32[] a 5', 1, 11, 'an array default must be written'),
        ('string<=2 s "abc"', 1, 13, 'string longer than its bound 2'),
        ('Point p 5', 1, 9, 'only primitive and string fields can have a default value'),
        ('int32[] A=5', 1, 1, 'a constant must have a primitive or string scalar type'),
        ('int32 A=', 1, 9, 'expected a constant value after "="'),
        ('string s "a"b"', 1, 10, 'unescaped " inside a quoted string'),
        ('a/b/c/d x', 1, 1, 'expected a field type'),
        ('pkg/srv/Foo x', 1, 1, 'expected "pkg/msg/Name" or "pkg/Name"'),
        ('int32 a-b', 1, 8, "unexpected character '-' in a field name"),
    ],
)
def test_errors_name_line_column_and_problem(
    text: str, line: int, column: int, problem: str
) -> None:
    with pytest.raises(InterfaceSyntaxError) as info:
        parse_message('pkg/msg/Bad', text, origin='Bad.msg')
    error = info.value
    assert (error.origin, error.line, error.column) == ('Bad.msg', line, column)
    assert problem in error.problem
    first_line = str(error).splitlines()[0]
    assert first_line.startswith(f'Bad.msg:{line}:{column}: ')
    # the message shows the offending line and a caret under the column
    shown, caret = str(error).splitlines()[1:3]
    assert caret.index('^') - 4 == column - 1
    assert shown.strip() == text.splitlines()[line - 1].strip()


def test_an_unknown_type_is_a_reference_not_a_syntax_error() -> None:
    # "float65" is a valid message name in the same package; resolving it fails later
    msg = parse_message('pkg/msg/M', 'float65 x')
    assert msg.fields[0].type == FieldType('pkg/msg/float65')


def test_service_and_action_separator_errors() -> None:
    with pytest.raises(InterfaceSyntaxError, match='exactly 1 "---" separator line'):
        parse_service('pkg/srv/S', 'int32 a')
    with pytest.raises(InterfaceSyntaxError, match='exactly 2 "---" separator line'):
        parse_action('pkg/action/A', 'int32 a\n---\nint32 b')
    with pytest.raises(InterfaceSyntaxError, match=r'S\.srv:3:6'):
        parse_service('pkg/srv/S', 'int32 a\n---\nint32', origin='S.srv')


def test_bundle_errors() -> None:
    with pytest.raises(InterfaceSyntaxError, match='expected "MSG: pkg/Name"'):
        parse_message_bundle('p/msg/M', 'int32 a\n' + '=' * 10 + '\nnot a header\n')


@pytest.mark.parametrize(
    'name', ['pkg', 'pkg/Name', 'pkg/foo/Name', 'pkg/msg/', '1pkg/msg/N', 'pkg/msg/N/x']
)
def test_invalid_type_names(name: str) -> None:
    with pytest.raises(TypeNameError, match='not a full ROS type name'):
        parse_message(name, 'int32 a')
