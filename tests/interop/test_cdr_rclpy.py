"""zros CDR is byte-compatible with real ROS 2 Jazzy (rclpy + Fast CDR) for every installed type.

For every message type the installed ROS packages define (plus the derived messages of their
services and actions):

* default-constructed messages serialise alike (this checks the parsing of default values);
* for random messages, rclpy's ``serialize_message`` and ``zros.cdr.encode`` give the same bytes,
  zros decodes rclpy's bytes back to the message and rclpy decodes zros' bytes back to it;
* fields over their bound are refused by ``zros.cdr.encode`` (and by rclpy).

Fast CDR leaves whatever was in memory in alignment padding, and rclpy returns a buffer sized
from an estimate, whose tail past the data is not initialised either (see :func:`layout_of`).
So the byte comparison masks the padding, found by the small CDR layout walker below, which is
written from the CDR rules independently of zros' own layout code.

Two differences this suite found, now handled by zros and kept as regression tests: rclpy's
buffers can end with more than 3 stray bytes (its size estimate aligns empty float64/int64/uint64
sequences, Fast CDR does not), which zros ignores as DDS readers do; and rclpy bounds
``string<=N`` in characters while C++ checks bytes, so zros decodes what fits in characters but
encodes only what fits in bytes.

Run more examples with ``ZROS_INTEROP_EXAMPLES=50 pytest tests/interop``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

pytest.importorskip(
    'rclpy.serialization',
    reason='rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable',
)

from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message

from tests.cdr.strategies import message_strategy
from tests.interop.rclpy_support import (
    field_to_rclpy,
    installed_interfaces,
    make_registry,
    message_type_names,
    rclpy_class,
    to_rclpy,
)
from zros.cdr import CdrError, decode, encode
from zros.cdr.model import FieldType, Kind, MessageDef
from zros.cdr.naming import attribute_name

REGISTRY = make_registry()
INTERFACES = installed_interfaces()
TYPES = message_type_names(INTERFACES)

#: test_msgs types that must be covered whatever else is installed
REQUIRED = [
    f'test_msgs/msg/{name}'
    for name in (
        'BasicTypes',
        'Arrays',
        'BoundedSequences',
        'UnboundedSequences',
        'BoundedPlainSequences',
        'WStrings',
        'Strings',
        'Constants',
        'Defaults',
        'Nested',
        'MultiNested',
        'Builtins',
        'Empty',
    )
]

EXAMPLES = int(os.environ.get('ZROS_INTEROP_EXAMPLES', '8'))
#: shrinking a failure of a big message takes minutes; ZROS_INTEROP_SHRINK=1 turns it on
SHRINK = os.environ.get('ZROS_INTEROP_SHRINK', '') == '1'

HEADER = b'\x00\x01\x00\x00'

random_examples = settings(
    max_examples=EXAMPLES,
    deadline=None,
    database=None,
    phases=list(Phase) if SHRINK else [Phase.explicit, Phase.generate],
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.filter_too_much,
    ],
)


# --- an independent CDR layout walker ---------------------------------------------------------

#: wire size (= alignment, 8 at most) of the primitive types
SIZES = {
    'bool': 1, 'byte': 1, 'char': 1, 'int8': 1, 'uint8': 1, 'int16': 2, 'uint16': 2,
    'int32': 4, 'uint32': 4, 'int64': 8, 'uint64': 8, 'float32': 4, 'float64': 8,
}  # fmt: skip


@dataclass
class Layout:
    """Where the bytes of one message body go (offsets count from the first byte after the header).

    With ``estimate`` set, the walk instead mimics the size estimate rmw_fastrtps uses to size
    rclpy's buffers (see :func:`layout_of`).
    """

    estimate: bool = False
    size: int = 0
    padding: set[int] = field(default_factory=set)
    #: (start, end, field path) of every value written
    spans: list[tuple[int, int, str]] = field(default_factory=list)
    wstrings: int = 0
    #: the length of rclpy's body (bytes after the header) for the same message
    rclpy_size: int = 0

    def align(self, n: int) -> None:
        pad = -self.size % n
        self.padding.update(range(self.size, self.size + pad))
        self.size += pad

    def put(self, n: int, path: str) -> None:
        self.spans.append((self.size, self.size + n, path))
        self.size += n

    def field_at(self, offset: int) -> str:
        for start, end, path in self.spans:
            if start <= offset < end:
                return path
        return '(padding)' if offset in self.padding else '(after the end)'


def layout_of(name: str, message: Any) -> Layout:
    """The CDR layout of a zros message, from its definition and its values.

    ``rclpy_size`` is set to the body length rclpy's ``serialize_message`` returns. rmw_fastrtps
    sizes that buffer from an estimate and hands all of it out, whatever Fast CDR wrote:

    * for a fixed-size ("plain") type, the size of the type rounded up to 4 bytes;
    * else a per-value estimate that also aligns an *empty* sequence of primitives to its
      element size (Fast CDR writes no such padding) and counts 4 bytes more per wstring than
      Fast CDR writes (a terminating NUL unit that is never written).

    The bytes between the end of the data and the end of the buffer are not initialised.
    """
    definition = REGISTRY.message_definition(name)
    layout = Layout()
    _walk_struct(layout, definition, message, '')
    estimate = Layout(estimate=True)
    _walk_struct(estimate, definition, message, '')
    if _is_fixed_size(definition):
        estimate.align(4)
    layout.rclpy_size = estimate.size
    return layout


def _is_fixed_size(definition: MessageDef) -> bool:
    return all(
        f.type.kind in (Kind.SCALAR, Kind.ARRAY)
        and not f.type.is_string
        and (f.type.is_primitive or _is_fixed_size(REGISTRY.message_definition(f.type.base)))
        for f in definition.fields
    )


def _walk_struct(layout: Layout, definition: MessageDef, value: Any, path: str) -> None:
    if not definition.fields:
        # an empty struct holds one uint8 placeholder, 0 (structure_needs_at_least_one_member)
        layout.put(1, f'{path}(placeholder)')
        return
    for f in definition.fields:
        sub = f'{path}.{f.name}' if path else f.name
        _walk_field(layout, f.type, getattr(value, attribute_name(f.name)), sub)


def _walk_field(layout: Layout, ftype: FieldType, value: Any, path: str) -> None:
    if ftype.kind is Kind.SCALAR:
        _walk_element(layout, ftype, value, path)
        return
    if ftype.kind is Kind.ARRAY:
        assert len(value) == ftype.length
    else:
        layout.align(4)
        layout.put(4, f'{path}(count)')
        if layout.estimate and ftype.is_primitive and not len(value):
            layout.align(SIZES[ftype.base])
    # element-wise: an empty sequence of primitives is not aligned to its element size
    for index, item in enumerate(value):
        _walk_element(layout, ftype.element, item, f'{path}[{index}]')


def _walk_element(layout: Layout, ftype: FieldType, value: Any, path: str) -> None:
    if ftype.is_primitive:
        size = SIZES[ftype.base]
        layout.align(size)
        layout.put(size, path)
    elif ftype.base == 'string':
        layout.align(4)
        layout.put(4 + len(value.encode()) + 1, path)  # u32 length incl. NUL, bytes, NUL
    elif ftype.base == 'wstring':
        # u32 count of UTF-16 code units, then each unit as 4 bytes; no terminator
        units = len(value.encode('utf-16-le')) // 2 + (1 if layout.estimate else 0)
        layout.align(4)
        layout.put(4 + 4 * units, path)
        layout.wstrings += 1
    else:
        _walk_struct(layout, REGISTRY.message_definition(ftype.base), value, path)


def assert_same_bytes(name: str, layout: Layout, ours: bytes, theirs: bytes) -> None:
    """zros' bytes match rclpy's everywhere but in padding, where zros must write zeros."""
    context = f'{name}\n  zros : {ours.hex()}\n  rclpy: {theirs.hex()}'
    assert ours[:4] == HEADER, f'zros header {ours[:4].hex()}: {context}'
    assert theirs[:4] == HEADER, f'rclpy header {theirs[:4].hex()}: {context}'
    assert len(ours) == 4 + layout.size, (
        f'zros wrote {len(ours)} bytes, the layout has 4 + {layout.size}: {context}'
    )
    assert len(theirs) == 4 + layout.rclpy_size, (
        f'rclpy returned {len(theirs) - len(ours)} bytes after the end of the message, the '
        f'walker expected {layout.rclpy_size - layout.size}: {context}'
    )
    nonzero_padding = [i for i in sorted(layout.padding) if ours[4 + i]]
    assert not nonzero_padding, (
        f'zros padding bytes not zero at body offsets {nonzero_padding}: {context}'
    )
    differences = [
        i for i in range(layout.size) if i not in layout.padding and ours[4 + i] != theirs[4 + i]
    ]
    if differences:
        described = ', '.join(
            f'{i} ({layout.field_at(i)}: zros {ours[4 + i]:02x}, rclpy {theirs[4 + i]:02x})'
            for i in differences[:8]
        )
        pytest.fail(f'bytes differ at body offsets {described}: {context}')


def _ids(names: list[str]) -> list[str]:
    return [
        n.replace('/msg/', '/').replace('/srv/', '/srv:').replace('/action/', '/action:')
        for n in names
    ]


# --- coverage ---------------------------------------------------------------------------------


def test_covers_the_installed_types() -> None:
    missing = [name for name in REQUIRED if name not in TYPES]
    assert not missing
    kinds = {name.split('/')[1] for name in INTERFACES}
    assert kinds == {'msg', 'srv', 'action'}
    for name in TYPES:
        assert rclpy_class(name).__name__, name


# --- 1. defaults ------------------------------------------------------------------------------


@pytest.mark.parametrize('name', TYPES, ids=_ids(TYPES))
def test_defaults_serialize_alike(name: str) -> None:
    default = REGISTRY.get_class(name)()
    ours = encode(default)
    theirs = serialize_message(rclpy_class(name)())
    assert_same_bytes(name, layout_of(name, default), ours, theirs)


@pytest.mark.parametrize('name', TYPES, ids=_ids(TYPES))
def test_zros_decodes_rclpy_defaults(name: str) -> None:
    theirs = serialize_message(rclpy_class(name)())
    assert decode(REGISTRY.get_class(name), theirs) == REGISTRY.get_class(name)()


@pytest.mark.parametrize('name', TYPES, ids=_ids(TYPES))
def test_rclpy_decodes_zros_defaults(name: str) -> None:
    ours = encode(REGISTRY.get_class(name)())
    assert deserialize_message(ours, rclpy_class(name)) == rclpy_class(name)()


# --- 2. random values -------------------------------------------------------------------------


@pytest.mark.parametrize('name', TYPES, ids=_ids(TYPES))
@random_examples
@given(data=st.data())
def test_rclpy_serializes_like_zros(name: str, data: Any) -> None:
    message = data.draw(message_strategy(REGISTRY, name), label='message')
    ours = encode(message)
    theirs = serialize_message(to_rclpy(REGISTRY, name, message))
    assert_same_bytes(name, layout_of(name, message), ours, theirs)


@pytest.mark.parametrize('name', TYPES, ids=_ids(TYPES))
@random_examples
@given(data=st.data())
def test_zros_decodes_rclpy_bytes(name: str, data: Any) -> None:
    message = data.draw(message_strategy(REGISTRY, name), label='message')
    theirs = serialize_message(to_rclpy(REGISTRY, name, message))
    decoded = decode(REGISTRY.get_class(name), theirs)
    assert decoded == message, f'{name}: rclpy bytes {theirs.hex()}'


@pytest.mark.parametrize('name', TYPES, ids=_ids(TYPES))
@random_examples
@given(data=st.data())
def test_rclpy_decodes_zros_bytes(name: str, data: Any) -> None:
    message = data.draw(message_strategy(REGISTRY, name), label='message')
    expected = to_rclpy(REGISTRY, name, message)
    ours = encode(message)
    decoded = deserialize_message(ours, rclpy_class(name))
    assert decoded == expected, f'{name}: zros bytes {ours.hex()}'


# --- the wstring wire format, spelled out -----------------------------------------------------


def test_wstring_wire_format() -> None:
    """Fast CDR writes a wstring as a u32 count of UTF-16 code units, then 4 bytes per unit.

    No terminating NUL is written, but rclpy's buffer is 4 bytes longer per wstring (its size
    estimate counts one more unit); those trailing bytes are not initialised.
    """
    name = 'test_msgs/msg/WStrings'
    text = 'a\u00e9\U0001f600'  # 1 + 1 + 2 (surrogate pair) UTF-16 code units
    message = REGISTRY.get_class(name)(
        wstring_value=text,
        wstring_value_default1='',
        wstring_value_default2='',
        wstring_value_default3='',
    )
    value = bytes.fromhex('0400000061000000e90000003dd8000000de0000')
    empty = bytes(4)
    # 3 empty defaults, wstring[3], 2 empty sequences
    body = value + empty * 3 + empty * 3 + empty * 2
    ours = encode(message)
    assert ours == HEADER + body
    theirs = serialize_message(to_rclpy(REGISTRY, name, message))
    assert theirs[: len(ours)] == ours
    assert len(theirs) == len(ours) + 4 * 7  # 7 wstrings
    assert deserialize_message(ours, rclpy_class(name)).wstring_value == text
    assert decode(REGISTRY.get_class(name), theirs).wstring_value == text


def test_empty_message_wire_format() -> None:
    """An empty struct is one 0 byte; rclpy pads the buffer to 4 bytes (with stray values)."""
    name = 'std_msgs/msg/Empty'
    ours = encode(REGISTRY.get_class(name)())
    assert ours == HEADER + b'\x00'
    theirs = serialize_message(rclpy_class(name)())
    assert len(theirs) == 8
    assert theirs[:5] == ours
    assert decode(REGISTRY.get_class(name), theirs) == REGISTRY.get_class(name)()


# --- known disagreements, spelled out --------------------------------------------------------


@pytest.mark.parametrize(
    ('name', 'field_name', 'count'),
    [
        ('std_srvs/srv/Empty_Event', 'request', 1),
        ('std_srvs/srv/Empty_Event', 'response', 1),
        ('test_msgs/msg/UnboundedSequences', 'constants_values', 3),
        ('test_msgs/msg/Arrays', 'constants_values', 3),
    ],
)
def test_sequence_of_empty_messages_writes_zero_placeholders(
    name: str, field_name: str, count: int
) -> None:
    """Each element of a sequence of empty messages is one placeholder byte, 0 in rclpy.

    The request and response of the event of every service with an empty request or response
    (std_srvs/srv/Empty, std_srvs/srv/Trigger, ...) are such sequences. numpy reuses freed small
    buffers, so a dirty buffer of the right size is freed first: an encoder that leaves the
    placeholder uninitialised then writes 0xa5 instead of 0.
    """
    definition = REGISTRY.message_definition(name)
    ftype = next(f.type for f in definition.fields if f.name == field_name)
    element = REGISTRY.get_class(ftype.base)
    message = REGISTRY.get_class(name)(**{field_name: [element() for _ in range(count)]})
    dirty = [np.full(count, 0xA5, np.uint8) for _ in range(4)]
    del dirty
    ours = encode(message)
    theirs = serialize_message(to_rclpy(REGISTRY, name, message))
    assert_same_bytes(name, layout_of(name, message), ours, theirs)


def test_zros_decodes_rclpy_bytes_with_size_estimate_slack() -> None:
    """zros ignores the stray bytes at the end of rclpy's buffers, as DDS readers do.

    rclpy hands out 4 stray bytes per empty float64/int64/uint64 sequence whose data would start
    4 bytes off an 8-byte boundary (rmw_fastrtps' size estimate aligns it, Fast CDR does not).

    ``std_msgs/msg/Float64MultiArray()``: zros writes 12 body bytes; rclpy's buffer is 16 bytes
    long, its last 4 bytes not initialised (its size estimate aligns the empty ``data`` to 8).
    """
    name = 'std_msgs/msg/Float64MultiArray'
    theirs = serialize_message(rclpy_class(name)())
    ours = encode(REGISTRY.get_class(name)())
    assert ours == HEADER + bytes(12)
    assert len(theirs) == len(ours) + 4
    assert theirs[: len(ours)] == ours
    assert decode(REGISTRY.get_class(name), theirs) == REGISTRY.get_class(name)()


def test_zros_decodes_rclpy_bounded_string_of_multibyte_characters() -> None:
    """rclpy bounds ``string<=N`` in characters: zros decodes such strings, but never sends them.

    rclpy, even with ``check_fields=True``, accepts 12 x 'é' (24 bytes) in a ``string<=22``,
    serialises it and reads it back. C++ readers check bytes, so zros refuses to encode it.
    """
    name = 'test_msgs/msg/Strings'
    reference = rclpy_class(name)(check_fields=True)
    reference.bounded_string_value = '\u00e9' * 12
    theirs = serialize_message(reference)
    assert deserialize_message(theirs, rclpy_class(name)) == reference
    decoded = decode(REGISTRY.get_class(name), theirs)
    assert decoded.bounded_string_value == '\u00e9' * 12
    with pytest.raises(CdrError, match='exceeds its bound 22'):
        encode(decoded)


# --- 3. bounds --------------------------------------------------------------------------------


def _bound_cases() -> list[tuple[str, str, str]]:
    cases = []
    for name in TYPES:
        for f in REGISTRY.message_definition(name).fields:
            if f.type.kind is Kind.BOUNDED:
                cases.append((name, f.name, 'elements'))
            if f.type.string_bound:
                cases.append((name, f.name, 'string'))
    return cases


BOUND_CASES = _bound_cases()

DTYPES = {
    'byte': np.uint8, 'char': np.uint8, 'int8': np.int8, 'uint8': np.uint8,
    'int16': np.int16, 'uint16': np.uint16, 'int32': np.int32, 'uint32': np.uint32,
    'int64': np.int64, 'uint64': np.uint64, 'float32': np.float32, 'float64': np.float64,
}  # fmt: skip


def _over_bound(ftype: FieldType, what: str) -> Any:
    """A zros value one element (or one byte) over the bound of a field."""
    if what == 'elements':
        count = ftype.length + 1
        if ftype.is_primitive:
            dtype = np.bool_ if ftype.base == 'bool' else DTYPES[ftype.base]
            return np.zeros(count, dtype)
        if ftype.is_string:
            return [''] * count
        return [REGISTRY.get_class(ftype.base)() for _ in range(count)]
    too_long = 'x' * (ftype.string_bound + 1)
    if ftype.kind is Kind.SCALAR:
        return too_long
    return [too_long] * (ftype.length if ftype.kind is Kind.ARRAY else 1)


@pytest.mark.parametrize(
    ('name', 'field_name', 'what'),
    BOUND_CASES,
    ids=[f'{_ids([name])[0]}.{f}:{what}' for name, f, what in BOUND_CASES],
)
def test_over_bound_is_refused(name: str, field_name: str, what: str) -> None:
    definition = REGISTRY.message_definition(name)
    ftype = next(f.type for f in definition.fields if f.name == field_name)
    value = _over_bound(ftype, what)

    message = REGISTRY.get_class(name)()
    setattr(message, attribute_name(field_name), value)
    with pytest.raises(CdrError):
        encode(message)

    rclpy_value = field_to_rclpy(REGISTRY, ftype, value)
    checked = rclpy_class(name)(check_fields=True)
    with pytest.raises(AssertionError):
        setattr(checked, field_name, rclpy_value)
    unchecked = rclpy_class(name)()
    setattr(unchecked, field_name, rclpy_value)
    if what == 'elements':
        # rmw_fastrtps refuses to serialise a sequence over its bound ("array size exceeds
        # upper bound"); it does not check string bounds, which only the Python setter does.
        with pytest.raises(Exception, match='serialize'):
            serialize_message(unchecked)
