"""pycdr2 as an independent reference encoder: its classes of zros types encode like zros."""

from __future__ import annotations

import sys
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pycdr2 = pytest.importorskip('pycdr2')

from pycdr2 import types as pt  # noqa: E402
from pycdr2._support import Endianness  # noqa: E402

from tests.cdr.strategies import message_strategy  # noqa: E402
from zros.cdr import StructSeq, decode, encode  # noqa: E402
from zros.cdr.pycdr2 import from_pycdr2, pycdr2_class, to_pycdr2  # noqa: E402
from zros.cdr.registry import TypeRegistry  # noqa: E402

REGISTRY = TypeRegistry('jazzy', ament=False)
NAMES = sorted(REGISTRY.typestore.fielddefs)


@pytest.mark.parametrize('name', NAMES)
@settings(
    max_examples=10,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(data=st.data())
def test_pycdr2_encodes_like_zros_and_round_trips(name: str, data: Any) -> None:
    message = data.draw(message_strategy(REGISTRY, name))
    cls = REGISTRY.get_class(name)
    target = pycdr2_class(name, REGISTRY)
    ours = encode(message)
    converted = to_pycdr2(message)
    assert type(converted) is target
    # Both write the 4-byte header and no trailing padding, so no adjustment is needed.
    theirs = converted.serialize()
    assert theirs == ours
    parsed = target.deserialize(ours)
    # to_pycdr2 gives the value types pycdr2's decoder gives (bytes for uint8 arrays, lists)
    assert parsed == converted
    assert from_pycdr2(parsed) == message
    # classes come from REGISTRY, so decode with its class, not by name (default registry)
    assert decode(cls, theirs) == message
    big = converted.serialize(endianness=Endianness.Big)
    assert big[:4] == b'\x00\x00\x00\x00'
    assert decode(cls, big) == message
    # decoded messages hold read-only array views and array-backed StructSeqs
    assert to_pycdr2(decode(cls, ours)).serialize() == ours


#: loops whose elements start at offsets the generated code may know statically (the first
#: alignment of an element skipped when the one before ended aligned) or may not
LOOPS = TypeRegistry('jazzy', ament=False)
LOOPS.register_text('loop_msgs/msg/Tail', 'string name\nfloat64 value')
LOOPS.register_text('loop_msgs/msg/Odd', 'float64 value\nstring name\nuint8 flag')
LOOPS.register_text('loop_msgs/msg/Mixed', 'int16 w\nstring s\nuint8 u\nfloat64 d\nuint8 v')
LOOPS.register_text(
    'loop_msgs/msg/Holder',
    'uint8 lead\nloop_msgs/Tail[] tails\nuint8 mid\nloop_msgs/Odd[2] odds\nint32 after\n'
    'loop_msgs/Tail[3] fixed\nfloat64 last\nloop_msgs/Mixed[] mixed\nint16 end\n'
    'loop_msgs/Tail[] again',
)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_loops_decode_at_every_element_offset(data: Any) -> None:
    message = data.draw(message_strategy(LOOPS, 'loop_msgs/msg/Holder'))
    cls = LOOPS.get_class('loop_msgs/msg/Holder')
    ours = encode(message)
    assert pycdr2_class('loop_msgs/msg/Holder', LOOPS).deserialize(ours) == to_pycdr2(message)
    assert to_pycdr2(message).serialize() == ours
    for form in (ours, bytearray(ours), memoryview(ours)):
        assert decode(cls, form) == message
    big = to_pycdr2(message).serialize(endianness=Endianness.Big)
    assert decode(cls, big) == message


def test_nested_type() -> None:
    cls = pycdr2_class('geometry_msgs/msg/PoseStamped', REGISTRY)
    assert cls.__idl_typename__ == 'geometry_msgs::msg::dds_::PoseStamped_'
    assert cls.__annotations__['pose'] is pycdr2_class('geometry_msgs/msg/Pose', REGISTRY)
    assert pycdr2_class(REGISTRY.get_class('geometry_msgs/msg/PoseStamped')) is cls
    assert pycdr2_class('geometry_msgs/PoseStamped', REGISTRY) is cls
    message = REGISTRY.get_class('geometry_msgs/msg/PoseStamped')(
        header={'stamp': {'sec': 5, 'nanosec': 7}, 'frame_id': 'map'},
        pose={'position': {'x': 1.5}, 'orientation': {'w': 1.0}},
    )
    obj = to_pycdr2(message)
    assert obj.header.stamp.sec == 5
    assert obj.header.frame_id == 'map'
    assert obj.pose.orientation.w == 1.0
    assert obj.serialize() == encode(message)
    assert from_pycdr2(obj) == message


def test_sequence_of_uniform_structs_is_a_struct_seq() -> None:
    cls = REGISTRY.get_class('geometry_msgs/msg/PoseArray')
    message = cls(poses=[{'position': {'x': float(i)}} for i in range(3)])
    assert isinstance(message.poses, StructSeq)
    back = from_pycdr2(to_pycdr2(message))
    assert isinstance(back.poses, StructSeq)
    assert back == message
    decoded = decode(cls, encode(message))
    assert [p.position.x for p in to_pycdr2(decoded).poses] == [0.0, 1.0, 2.0]


def test_value_types() -> None:
    registry = TypeRegistry('jazzy', ament=False)
    registry.register_text(
        'pkg_x/msg/V',
        'byte[2] raw\nchar c\nuint8[] seq\nbool[2] flags\nstring<=5 short\nstring[2] words\n'
        'float32[<=3] floats\nint32[<=70000] big',
    )
    target = pycdr2_class('pkg_x/msg/V', registry)
    assert target.__annotations__['c'] == pt.uint8
    assert target.__annotations__['short'] == pt.bounded_str[5]
    assert target.__annotations__['floats'] == pt.sequence[pt.float32, 3]
    # pycdr2 refuses sequence bounds above 65535: the bridge leaves them unbounded
    assert target.__annotations__['big'] == pt.sequence[pt.int32]
    message = registry.get_class('pkg_x/msg/V')(
        raw=[1, 255],
        c=65,
        seq=[3, 4],
        flags=[True, False],
        short='abc',
        words=['a', 'b'],
        floats=[0.5],
        big=[1, -2],
    )
    obj = to_pycdr2(message)
    assert obj.raw == b'\x01\xff'
    assert obj.c == 65
    assert obj.seq == [3, 4]
    assert obj.flags == [True, False]
    assert obj.floats == [0.5]
    assert obj.serialize() == encode(message)
    back = from_pycdr2(obj)
    assert back == message
    assert back.raw.dtype == np.uint8
    assert back.flags.dtype == np.bool_
    assert back.raw.flags.writeable


def test_keyword_field_uses_attribute_name() -> None:
    registry = TypeRegistry('jazzy', ament=False)
    registry.register_text('pkg_x/msg/K', 'int32 from\nstring lambda')
    message = registry.get_class('pkg_x/msg/K')(from_=3, lambda_='x')
    obj = to_pycdr2(message)
    assert obj.from_ == 3
    assert obj.serialize() == encode(message)
    assert from_pycdr2(obj) == message


def test_empty_message() -> None:
    cls = pycdr2_class('std_msgs/msg/Empty', REGISTRY)
    assert list(cls.__annotations__) == ['structure_needs_at_least_one_member']
    assert cls.__annotations__['structure_needs_at_least_one_member'] == pt.uint8
    message = REGISTRY.get_class('std_msgs/msg/Empty')()
    obj = to_pycdr2(message)
    assert obj.serialize() == encode(message) == b'\x00\x01\x00\x00\x00'
    assert from_pycdr2(cls.deserialize(encode(message))) == message


def test_from_a_foreign_pycdr2_class() -> None:
    point = pycdr2.make_idl_struct(
        'Point',
        'geometry_msgs::msg::dds_::Point_',
        {'x': pt.float64, 'y': pt.float64, 'z': pt.float64},
    )
    message = from_pycdr2(point(x=1.0, y=2.0, z=3.0), registry=REGISTRY)
    assert message == REGISTRY.get_class('geometry_msgs/msg/Point')(x=1.0, y=2.0, z=3.0)
    named = from_pycdr2(point(x=1.0, y=2.0, z=3.0), 'geometry_msgs/msg/Point', REGISTRY)
    assert named == message


def test_classes_are_cached_per_registry() -> None:
    other = TypeRegistry('jazzy', ament=False)
    first = pycdr2_class('std_msgs/msg/Header', REGISTRY)
    assert pycdr2_class('std_msgs/msg/Header', REGISTRY) is first
    assert pycdr2_class('std_msgs/msg/Header', other) is not first


def test_wstring_raises_not_implemented() -> None:
    registry = TypeRegistry('jazzy', ament=False)
    registry.register_text('pkg_x/msg/W', 'wstring w')
    registry.register_text('pkg_x/msg/Outer', 'int32 a\npkg_x/W inner')
    with pytest.raises(NotImplementedError, match="pkg_x/msg/W field 'w'"):
        pycdr2_class('pkg_x/msg/W', registry)
    with pytest.raises(NotImplementedError, match='wstring'):
        pycdr2_class('pkg_x/msg/Outer', registry)


def test_missing_pycdr2_raises_import_error(monkeypatch: pytest.MonkeyPatch) -> None:
    message = REGISTRY.get_class('std_msgs/msg/String')(data='x')
    monkeypatch.setitem(sys.modules, 'pycdr2', None)
    with pytest.raises(ImportError, match='pip install pycdr2'):
        pycdr2_class('std_msgs/msg/String', REGISTRY)
    with pytest.raises(ImportError, match='pip install pycdr2'):
        to_pycdr2(message)
