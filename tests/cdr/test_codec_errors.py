"""Every way encoding or decoding can fail gives a CdrError that names the field and offset."""

from __future__ import annotations

import struct
import tracemalloc

import numpy as np
import pytest

from zros import cdr
from zros.cdr import CdrError
from zros.cdr.registry import TypeRegistry

REGISTRY = TypeRegistry('jazzy', paths=[], ament=False)
REGISTRY.register_text('err_msgs/msg/Bounded', 'string<=3 name\nint16[<=2] values\nuint8 tail')
REGISTRY.register_text('err_msgs/msg/Wide', 'wstring text\nwstring<=2 short')
REGISTRY.register_text('err_msgs/msg/Corners', 'geometry_msgs/Point32[<=2] corners\nuint8 tail')


def cls(name: str) -> type[cdr.Message]:
    return REGISTRY.get_class(name)


# --- encoding ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('name', 'setup', 'field', 'reason'),
    [
        (
            'geometry_msgs/msg/Twist',
            lambda m: setattr(m.linear, 'y', 'fast'),
            'linear.y',
            "expected a float for float64, got str 'fast'",
        ),
        (
            'std_msgs/msg/Int8',
            lambda m: setattr(m, 'data', 300),
            'data',
            '300 is out of the range of int8 [-128, 127]',
        ),
        (
            'std_msgs/msg/UInt64',
            lambda m: setattr(m, 'data', -1),
            'data',
            '-1 is out of the range of uint64',
        ),
        (
            'std_msgs/msg/Int32',
            lambda m: setattr(m, 'data', 1.5),
            'data',
            'expected an int for int32, got float 1.5',
        ),
        (
            'std_msgs/msg/Float32',
            lambda m: setattr(m, 'data', 1e39),
            'data',
            'too large for float32',
        ),
        (
            'std_msgs/msg/String',
            lambda m: setattr(m, 'data', b'bytes'),
            'data',
            'expected str, got bytes',
        ),
        (
            'err_msgs/msg/Bounded',
            lambda m: setattr(m, 'name', 'long'),
            'name',
            'string of 4 bytes exceeds its bound 3',
        ),
        (
            'err_msgs/msg/Bounded',
            lambda m: setattr(m, 'values', [1, 2, 3]),
            'values',
            '3 elements exceed the bound of 2',
        ),
        (
            'err_msgs/msg/Bounded',
            lambda m: setattr(m, 'values', [1, 70000]),
            'values',
            'value 70000 is out of the range of int16',
        ),
        (
            'sensor_msgs/msg/Imu',
            lambda m: setattr(m, 'orientation_covariance', [0.0] * 8),
            'orientation_covariance',
            'expected exactly 9 elements, got 8',
        ),
        (
            'sensor_msgs/msg/Imu',
            lambda m: setattr(m, 'header', 'nope'),
            'header',
            'expected std_msgs/msg/Header, got str',
        ),
        (
            'sensor_msgs/msg/Imu',
            lambda m: setattr(m.header, 'stamp', None),
            'header.stamp',
            'expected builtin_interfaces/msg/Time, got NoneType',
        ),
        (
            'std_msgs/msg/Float64MultiArray',
            lambda m: setattr(m, 'data', [[1.0], [2.0]]),
            'data',
            'expected a 1-D sequence',
        ),
        (
            'sensor_msgs/msg/JointState',
            lambda m: setattr(m, 'name', ['a', 5]),
            'name[1]',
            'expected str, got int',
        ),
        (
            'err_msgs/msg/Wide',
            lambda m: setattr(m, 'short', 'abc'),
            'short',
            'wstring of 3 characters exceeds its bound 2',
        ),
        (
            'geometry_msgs/msg/Polygon',
            lambda m: setattr(m, 'points', [object()]),
            'points',
            'element 0: expected geometry_msgs/msg/Point32, got object',
        ),
        (
            'geometry_msgs/msg/Polygon',
            lambda m: setattr(m, 'points', [cls('geometry_msgs/msg/Point32')(), 5]),
            'points',
            'element 1: expected geometry_msgs/msg/Point32, got int',
        ),
        (
            'err_msgs/msg/Corners',
            lambda m: setattr(m, 'corners', [cls('geometry_msgs/msg/Point32')()] * 3),
            'corners',
            '3 elements exceed the bound of 2',
        ),
    ],
)
def test_encode_errors(name: str, setup: object, field: str, reason: str) -> None:
    message = cls(name)()
    setup(message)  # type: ignore[operator]
    with pytest.raises(CdrError) as info:
        cdr.encode(message)
    assert info.value.field == field
    assert info.value.type_name == name
    assert reason in str(info.value)
    assert str(info.value).startswith(f'cannot encode {name}: field {field!r}: ')


def test_a_struct_sequence_encodes_the_same_from_every_form_it_takes() -> None:
    Point32, Polygon = cls('geometry_msgs/msg/Point32'), cls('geometry_msgs/msg/Polygon')
    rows = [(1.0, 2.0, 3.0), (4.0, 5.0, 6.0), (7.0, 8.0, 9.0)]
    objects = [Point32(x=x, y=y, z=z) for x, y, z in rows]
    expected = HEADER + _u32(3) + struct.pack('<9f', *[v for row in rows for v in row])
    table = np.array(rows, dtype=[('x', '<f4'), ('y', '<f4'), ('z', '<f4')])
    forms = {
        'objects': objects,
        'tuple': tuple(objects),
        'generator': (p for p in objects),
        'dicts': [{'x': x, 'y': y, 'z': z} for x, y, z in rows],
        'mixed': [objects[0], {'x': 4.0, 'y': 5.0, 'z': 6.0}, objects[2]],
        'array': table,
        'float64 array': table.astype([('x', '<f8'), ('y', '<f8'), ('z', '<f8')]),
    }
    for form, value in forms.items():
        message = Polygon()
        message.points = value
        assert cdr.encode(message) == expected, form
    assert cdr.encode(Polygon(points=objects)) == expected
    assert cdr.encode(Polygon(points=[])) == HEADER + _u32(0)


def test_encoding_something_that_is_not_a_message() -> None:
    with pytest.raises(TypeError, match='expected a zros message, got dict'):
        cdr.encode({'data': 1})  # type: ignore[arg-type]


# --- decoding ---------------------------------------------------------------------------


def _u32(value: int) -> bytes:
    return struct.pack('<I', value)


HEADER = b'\x00\x01\x00\x00'


@pytest.mark.parametrize(
    ('name', 'data', 'field', 'offset', 'reason'),
    [
        ('std_msgs/msg/String', b'\x00\x01', '', 0, 'shorter than the 4-byte CDR header'),
        (
            'std_msgs/msg/String',
            b'\x00\x07\x00\x00' + _u32(1) + b'\x00',
            '',
            0,
            'unsupported encapsulation 0007',
        ),
        (
            'std_msgs/msg/String',
            b'\x01\x01\x00\x00' + _u32(1) + b'\x00',
            '',
            0,
            'unsupported encapsulation 0101',
        ),
        (
            'std_msgs/msg/String',
            HEADER + b'\x05\x00',
            'data',
            4,
            'the buffer ends too early (6 bytes)',
        ),
        (
            'std_msgs/msg/String',
            HEADER + _u32(100) + b'abc\x00',
            'data',
            4,
            'string of 99 bytes runs past the end of the buffer (12 bytes)',
        ),
        (
            'std_msgs/msg/String',
            HEADER + _u32(4) + b'abcd',
            'data',
            4,
            'does not end with a NUL byte',
        ),
        ('std_msgs/msg/String', HEADER + _u32(3) + b'\xff\xfe\x00', 'data', 4, 'invalid UTF-8'),
        (
            'std_msgs/msg/String',
            HEADER + _u32(1) + b'\x00' + b'garbage!',
            '',
            9,
            '8 bytes left after the end of the message (at most 3 padding bytes are allowed); the '
            'data may be of another type or version',
        ),
        (
            'err_msgs/msg/Bounded',
            HEADER + _u32(6) + b'abcde\x00',
            'name',
            4,
            'string of 5 characters exceeds its bound 3',
        ),
        (
            'err_msgs/msg/Bounded',
            HEADER + _u32(1) + b'\x00\x00\x00\x00' + _u32(3) + b'\x00' * 7,
            'values',
            12,
            '3 elements exceed the bound 2',
        ),
        (
            'geometry_msgs/msg/Twist',
            HEADER + b'\x00' * 40,
            'angular.z',
            44,
            'the buffer ends too early (44 bytes)',
        ),
        (
            'sensor_msgs/msg/Imu',
            HEADER + bytes(12) + b'\x00' * 100,
            'orientation_covariance',
            52,
            'array of 9 elements runs past the end of the buffer (116 bytes)',
        ),
        # an Image (no frame id, encoding 'x') whose data count claims 2 GiB
        (
            'sensor_msgs/msg/Image',
            HEADER
            + bytes(8)
            + _u32(1)
            + b'\x00'
            + bytes(3)
            + bytes(8)
            + _u32(2)
            + b'x\x00'
            + b'\x00'
            + bytes(1)
            + _u32(0)
            + _u32(2**31)
            + b'ab',
            'data',
            40,
            'the buffer ends too early',
        ),
        (
            'sensor_msgs/msg/JointState',
            HEADER + bytes(8) + _u32(1) + b'\x00' + bytes(3) + _u32(2**32 - 1),
            'name',
            20,
            '4294967295 elements cannot fit in the 0 bytes left',
        ),
        (
            'geometry_msgs/msg/PoseArray',
            HEADER + bytes(8) + _u32(1) + b'\x00' + bytes(3) + _u32(10**6) + bytes(56),
            'poses',
            20,
            'the buffer ends too early',
        ),
        (
            'err_msgs/msg/Wide',
            HEADER + _u32(2) + _u32(0x41) + _u32(0x110000),
            'text',
            4,
            'code unit above 0xFFFF',
        ),
        ('err_msgs/msg/Wide', HEADER + _u32(2**30), 'text', 4, 'runs past the end of the buffer'),
    ],
)
def test_decode_errors(name: str, data: bytes, field: str, offset: int, reason: str) -> None:
    for buffer in (data, bytearray(data), memoryview(data)):
        with pytest.raises(CdrError) as info:
            cdr.decode(cls(name), buffer, strict=True)
        assert reason in str(info.value)
        assert info.value.field == field
        assert info.value.offset == offset
        assert info.value.type_name == name


def test_trailing_bytes_are_ignored_unless_strict() -> None:
    # rclpy's serializer leaves stray bytes after some messages; DDS readers ignore them
    String = cls('std_msgs/msg/String')
    data = HEADER + _u32(2) + b'a\x00' + b'astrtps_'
    for buffer in (data, bytearray(data), memoryview(data)):
        assert cdr.decode(String, buffer).data == 'a'
        with pytest.raises(CdrError, match='8 bytes left after the end of the message'):
            cdr.decode(String, buffer, strict=True)
    assert String.deserialize(data).data == 'a'
    # wstring types accept stray bytes even when strict (Fast DDS adds 4 per wstring)
    assert (
        cdr.decode(cls('err_msgs/msg/Wide'), HEADER + bytes(8) + b'junkjunk', strict=True).text
        == ''
    )


def test_bounded_strings_count_characters_when_decoding() -> None:
    # rclpy checks bounds in characters and writes 'é' * 3 (6 bytes) into a string<=3
    Bounded = cls('err_msgs/msg/Bounded')
    text = '\u00e9' * 3
    data = HEADER + _u32(7) + text.encode() + b'\x00' + bytes(1) + _u32(0) + b'\x00'
    decoded = cdr.decode(Bounded, data, strict=True)
    assert decoded.name == text
    with pytest.raises(CdrError, match='string of 6 bytes exceeds its bound 3'):
        cdr.encode(decoded)  # C++ readers check bytes: zros never sends it


def test_decoding_something_that_is_not_a_buffer() -> None:
    with pytest.raises(CdrError, match='expected bytes, bytearray or memoryview, got str'):
        cdr.decode(cls('std_msgs/msg/String'), 'text')  # type: ignore[arg-type]


def test_a_string_counted_zero_reads_as_empty_and_the_fields_after_it_in_place() -> None:
    # writers put at least the NUL (count 1); a count of 0 is read as '' (no bytes to skip),
    # in the first field (read at constant offsets) and later ones, from bytes or a view
    Bounded = cls('err_msgs/msg/Bounded')
    data = HEADER + _u32(0) + _u32(2) + b'\x05\x00\x06\x00' + b'\x07'
    for buf in (data, memoryview(data), bytearray(data)):
        decoded = cdr.decode(Bounded, buf, strict=True)
        assert (decoded.name, list(decoded.values), decoded.tail) == ('', [5, 6], 7)


def test_decoding_by_something_that_names_no_type() -> None:
    data = cdr.encode(cls('std_msgs/msg/String')(data='a'))
    for wrong in (123, None, b'std_msgs/msg/String', dict):
        with pytest.raises(TypeError, match='decode takes a type name or a message class'):
            cdr.decode(wrong, data)  # type: ignore[arg-type]


def test_decoding_by_name_reads_the_name_however_it_is_spelled() -> None:
    class Name(str):
        pass

    data = cdr.encode(cls('std_msgs/msg/String')(data='spelled'))
    for name in ('std_msgs/msg/String', 'std_msgs/String', Name('std_msgs/msg/String')):
        assert cdr.decode(name, data).data == 'spelled'
        assert cdr.decode(name, data).data == 'spelled'  # the second time from the cache
    with pytest.raises(CdrError, match='std_msgs/msg/String'):
        cdr.decode('std_msgs/String', data[:9])  # cut short: the explained error, by name too


def test_trailing_padding_is_accepted_and_its_content_ignored() -> None:
    String = cls('std_msgs/msg/String')
    for pad in (b'\x00', b'\x55\x00', b'\xaa\xbb\xcc'):
        assert cdr.decode(String, HEADER + _u32(2) + b'a\x00' + pad).data == 'a'
    # the content of alignment padding is ignored too (Fast CDR leaves bytes there)
    Header = cls('std_msgs/msg/Header')
    Imu = cls('sensor_msgs/msg/Imu')
    clean = cdr.encode(Imu(header=Header(frame_id='imu')))
    clean = cdr.encode(Imu(header=Header(frame_id='imu1')))
    dirty = bytearray(clean)
    # body: stamp 0-8, length 8-12, 'imu1\0' 12-17, 7 bytes of padding up to 24
    assert dirty[4 + 17 : 4 + 24] == bytes(7)
    dirty[4 + 17 : 4 + 24] = b'\x77' * 7
    assert cdr.decode(Imu, bytes(dirty)) == cdr.decode(Imu, clean)
    # empty messages: one placeholder byte, whatever its value, plus padding
    Empty = cls('std_msgs/msg/Empty')
    assert cdr.decode(Empty, b'\x00\x01\x00\x00\x00\x55\x00\x00') == Empty()


def test_malformed_counts_do_not_allocate() -> None:
    JointState = cls('sensor_msgs/msg/JointState')
    hostile = HEADER + bytes(8) + _u32(1) + b'\x00' + bytes(3) + _u32(2**32 - 1) + bytes(64)
    tracemalloc.start()
    try:
        with pytest.raises(CdrError):
            cdr.decode(JointState, hostile)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 256 * 1024


def test_errors_after_a_failure_leave_the_codec_working() -> None:
    String = cls('std_msgs/msg/String')
    with pytest.raises(CdrError):
        cdr.decode(String, b'\x00\x01\x00\x00\xff')
    assert cdr.decode(String, cdr.encode(String(data='ok'))).data == 'ok'
    broken = String()
    broken.data = 3  # type: ignore[assignment]
    with pytest.raises(CdrError):
        cdr.encode(broken)
    assert cdr.encode(String(data='ok')) == HEADER + _u32(3) + b'ok\x00'
