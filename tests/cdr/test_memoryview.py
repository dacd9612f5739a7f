"""Decoding a memoryview (a zero-copy slice of a chunk or a receive buffer) gives the message
decoding the same bytes gives, whatever the view's offset, format or writability."""

from __future__ import annotations

import importlib.util
import struct
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from zros import cdr
from zros.cdr import CdrError, Message
from zros.cdr.codegen.decode_builder import HEAD_BYTES
from zros.cdr.codegen.decoder import LONG_TEXT

BENCHMARK = Path(__file__).resolve().parents[2] / 'benchmarks' / 'codec.py'


def _codec_benchmark() -> ModuleType:
    spec = importlib.util.spec_from_file_location('zros_codec_benchmark', BENCHMARK)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


#: the messages benchmarks/codec.py times (its memoryview column times the same ones)
MESSAGES: dict[str, Message] = _codec_benchmark().build_messages()


def slices(data: bytes, tail: int = 0) -> Iterator[tuple[str, memoryview]]:
    """``data`` and ``tail`` bytes after it as memoryviews: whole, and sliced from bigger
    buffers at aligned and odd offsets, read-only and writable."""
    yield 'whole', memoryview(data + b'\xee' * tail)
    for offset in (8, 13):
        padded = b'\xee' * offset + data + b'\xee' * 9
        yield f'read-only at {offset}', memoryview(padded)[offset : offset + len(data) + tail]
    writable = bytearray(3) + bytearray(data) + bytearray(9)
    yield 'writable at 3', memoryview(writable)[3 : 3 + len(data) + tail]


@pytest.mark.parametrize('name', list(MESSAGES))
def test_a_memoryview_decodes_as_its_bytes(name: str) -> None:
    message = MESSAGES[name]
    cls = type(message)
    data = cdr.encode(message)
    expected = cdr.decode(cls, data)
    for label, view in slices(data):
        for _ in range(2):  # the first view compiles the view decoder, later ones run it
            assert cdr.decode(cls, view) == expected, label
            assert cls.deserialize(view, strict=True) == expected, label
    for label, view in slices(data, tail=4):
        assert cdr.decode(cls, view) == expected, label
        with pytest.raises(CdrError, match='4 bytes left after the end of the message'):
            cdr.decode(cls, view, strict=True)


@pytest.mark.parametrize('name', ['LaserScan(720)', 'Image 640x480', 'PoseArray(1000)'])
def test_arrays_decoded_from_a_memoryview_view_its_buffer(name: str) -> None:
    message = MESSAGES[name]
    raw = bytearray(5) + bytearray(cdr.encode(message))
    decoded = cdr.decode(type(message), memoryview(raw)[5:])
    arrays = [
        value
        for value in (getattr(decoded, field) for field in decoded._fields)
        if isinstance(value, np.ndarray)
    ] or [decoded.poses.array]
    buffer = np.frombuffer(raw, np.uint8)
    for array in arrays:
        assert np.shares_memory(array, buffer)
        assert array.flags.writeable  # as the buffer is


def _formats(data: bytes) -> Iterator[tuple[str, memoryview]]:
    """``data`` (padded to 8 bytes) as memoryviews of other formats and shapes."""
    padded = data + bytes(-len(data) % 8)
    view = memoryview(padded)
    yield 'char', view.cast('c')
    yield 'signed', view.cast('b')
    yield 'uint16', view.cast('H')
    yield 'float64', view.cast('d')
    yield '2-D', view.cast('B', shape=[len(padded) // 8, 8])


LONG = 'x' * (2 * LONG_TEXT)


@pytest.mark.parametrize(
    'message',
    [
        MESSAGES['String'],
        MESSAGES['Twist'],
        MESSAGES['Imu'],
        MESSAGES['TFMessage(10)'],
        MESSAGES['String'].__class__(data=LONG),
    ],
    ids=['String', 'Twist', 'Imu', 'TFMessage', 'long String'],
)
def test_a_memoryview_of_any_format_decodes_its_bytes(message: Message) -> None:
    data = cdr.encode(message)
    for label, view in _formats(data):
        for _ in range(2):
            assert cdr.decode(type(message), view) == message, label


@pytest.mark.parametrize('size', [LONG_TEXT - 1, LONG_TEXT, LONG_TEXT + 1, 3 * LONG_TEXT])
def test_a_text_of_any_length_decodes_from_a_view(size: int) -> None:
    # a long text decodes from a memoryview of the view's copy, a short one from a slice
    String = MESSAGES['String'].__class__
    text = ('é' * size)[: size // 2] + 'x' * (size - 2 * (size // 2))
    data = cdr.encode(String(data=text))
    for label, view in slices(data):
        assert cdr.decode(String, view).data == text, label
    with pytest.raises(CdrError, match='does not end with a NUL byte'):
        cdr.decode(String, memoryview(data[:-1] + b'y'))
    broken = bytearray(data)
    broken[len(data) // 2] = 0xFF  # not UTF-8
    with pytest.raises(CdrError, match='std_msgs/msg/String'):
        cdr.decode(String, memoryview(bytes(broken)))


def test_big_endian_data_decodes_from_a_memoryview() -> None:
    String = MESSAGES['String'].__class__
    Twist = MESSAGES['Twist'].__class__
    text = b'\x00\x00\x00\x00' + struct.pack('>I', 3) + b'ab\x00'
    twist = b'\x00\x00\x00\x00' + struct.pack('>6d', 1, 2, 3, 4, 5, 6)
    for label, view in slices(text):
        assert cdr.decode(String, view).data == 'ab', label
    for label, view in slices(twist):
        decoded = cdr.decode(Twist, view)
        assert (decoded.linear.x, decoded.angular.z) == (1.0, 6.0), label


ARRAY_MESSAGES = [
    'LaserScan(720)',
    'Image 640x480',
    'PointCloud2(100k)',
    'Odometry',
    'PoseArray(1000)',
]


@pytest.mark.parametrize('name', ARRAY_MESSAGES)
def test_a_memoryview_of_any_format_with_arrays_decodes_its_bytes(name: str) -> None:
    # the text before the arrays is read from a copy of the view's head, whatever its format
    cls = type(MESSAGES[name])
    data = cdr.encode(MESSAGES[name])
    expected = cdr.decode(cls, data)
    for label, view in _formats(data):
        for _ in range(2):
            assert cdr.decode(cls, view) == expected, label


def test_text_past_the_copied_head_and_views_shorter_than_it_decode() -> None:
    Image = MESSAGES['Image 640x480'].__class__
    frame = 'f' * (2 * HEAD_BYTES)
    for image in (
        Image(header={'frame_id': 'cam'}, encoding='mono8', data=np.ones(3, np.uint8)),
        Image(header={'frame_id': frame}, encoding='rgb8', data=np.arange(12, dtype=np.uint8)),
        Image(header={'frame_id': 'cam'}, encoding='e' * HEAD_BYTES, data=np.ones(3, np.uint8)),
    ):
        data = cdr.encode(image)
        for label, view in slices(data):
            assert cdr.decode(Image, view) == image, label


@pytest.mark.parametrize('name', ['LaserScan(720)', 'Image 640x480', 'PointCloud2(100k)'])
def test_a_truncated_or_empty_view_fails_as_its_bytes_do(name: str) -> None:
    message = MESSAGES[name]
    data = cdr.encode(message)
    cut = next(i for i in range(30, len(data)) if data[i - 1])  # inside the frame id's text
    for size in (0, 3, 16, cut, len(data) - 1):
        with pytest.raises(CdrError) as from_bytes:
            cdr.decode(type(message), data[:size])
        for label, view in slices(data[:size]):
            with pytest.raises(CdrError) as from_view:
                cdr.decode(type(message), view)
            assert str(from_view.value) == str(from_bytes.value), (size, label)
