"""How much decoding allocates for its input: the bounds the README states, checked on the
most expensive inputs per byte (empty and tiny elements) of each shape of type.

Every element of a sequence takes at least one byte on the wire (an empty message is one
placeholder byte, a string or sequence its 4-byte count) and counts are checked against the
bytes left before any loop, so allocation is linear in the input; the factor depends on how
many Python objects one element makes. Sizes of Python objects vary a little between CPython
versions: the bounds leave about 25 % of room over the measured factors.
"""

from __future__ import annotations

import gc
import struct
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import pytest

from zros.cdr import TypeRegistry, decode

HEADER = b'\x00\x01\x00\x00'
COUNT = 50_000
TYPES = {
    'alloc_test/msg/Strings': 'string[] items',
    'alloc_test/msg/WStrings': 'wstring[] items',
    'alloc_test/msg/Names': 'std_msgs/String[] names',
    'alloc_test/msg/Blob': 'uint8[] data',
    'alloc_test/msg/Blobs': 'alloc_test/Blob[] blobs',
    'alloc_test/msg/Inner': 'std_msgs/String name',
    'alloc_test/msg/Outer': 'alloc_test/Inner[] items',
    'alloc_test/msg/Bytes': 'uint8[] data',
    'alloc_test/msg/Bools': 'bool[] data',
    'alloc_test/msg/Empties': 'std_msgs/Empty[] items',
    'alloc_test/msg/Points': 'geometry_msgs/Point32[] points',
}


def _u32(value: int) -> bytes:
    return struct.pack('<I', value)


def _sequence(element: bytes, count: int = COUNT) -> bytes:
    return HEADER + _u32(count) + element * count


#: (type, input, the stated bound of allocated bytes per input byte)
CASES: dict[str, tuple[str, bytes, float]] = {
    # a Python str per element; the empty string is shared
    'string[] of empty strings': ('alloc_test/msg/Strings', _sequence(_u32(0)), 2.5),
    'string[] of 2 characters': ('alloc_test/msg/Strings', _sequence(_u32(3) + b'ab\0\0'), 9),
    'wstring[] of empty strings': ('alloc_test/msg/WStrings', _sequence(_u32(0)), 2.5),
    # a message object (and its str) per element
    'String[] of empty strings': ('alloc_test/msg/Names', _sequence(_u32(0)), 15),
    'String[] of 2 characters': ('alloc_test/msg/Names', _sequence(_u32(3) + b'ab\0\0'), 15),
    'Blob[] of 1-byte uint8[]': ('alloc_test/msg/Blobs', _sequence(_u32(1) + b'x\0\0\0'), 25),
    # one more level of messages: ~10x more for the same 4 bytes
    'Outer[] (Inner{String}) empty': ('alloc_test/msg/Outer', _sequence(_u32(0)), 28),
    # views of the input: nothing per element
    'uint8[]': ('alloc_test/msg/Bytes', HEADER + _u32(16 * COUNT) + b'x' * 16 * COUNT, 0.01),
    'Empty[] (StructSeq)': ('alloc_test/msg/Empties', _sequence(b'\0'), 0.01),
    'Point32[] (StructSeq)': ('alloc_test/msg/Points', _sequence(bytes(12)), 0.01),
    # bools are checked and copied
    'bool[]': ('alloc_test/msg/Bools', HEADER + _u32(16 * COUNT) + b'\x01' * 16 * COUNT, 1.1),
}


@pytest.fixture(scope='module')
def registry() -> TypeRegistry:
    types = TypeRegistry(paths=[])
    for name, text in TYPES.items():
        types.register_text(name, text)
    return types


def allocated(action: Callable[[], object]) -> tuple[int, object]:
    """Peak bytes allocated while ``action`` runs (its result kept alive)."""
    gc.collect()
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        result = action()
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    return peak, result


@pytest.mark.parametrize('case', CASES)
def test_decoding_allocates_at_most_the_stated_factor(registry: TypeRegistry, case: str) -> None:
    type_name, data, bound = CASES[case]
    cls = registry.get_class(type_name)
    decode(cls, HEADER + _u32(0))  # the codec is generated once, before measuring
    peak, message = allocated(lambda: decode(cls, data))
    assert message is not None
    factor = peak / len(data)
    assert factor <= bound, f'{case}: {peak} bytes for {len(data)} ({factor:.1f}x > {bound}x)'


def test_iterating_a_struct_seq_of_empty_messages_is_bounded(registry: TypeRegistry) -> None:
    # the one-byte elements become message objects only when iterated: ~48 bytes per byte
    data = _sequence(b'\0')
    message = decode(registry.get_class('alloc_test/msg/Empties'), data)
    peak, items = allocated(lambda: list(message.items))
    assert len(items) == COUNT  # type: ignore[arg-type]
    assert peak / len(data) <= 60


def test_a_count_larger_than_the_bytes_left_allocates_nothing(registry: TypeRegistry) -> None:
    from zros.cdr import CdrError

    hostile = HEADER + _u32(2**32 - 1) + bytes(64)

    def refused(cls: type) -> str:
        try:
            decode(cls, hostile)
        except CdrError as exc:
            return str(exc)
        raise AssertionError(f'{cls} decoded {hostile!r}')

    for type_name in ('alloc_test/msg/Names', 'alloc_test/msg/Empties', 'alloc_test/msg/Strings'):
        cls = registry.get_class(type_name)
        refused(cls)  # the first failure compiles the tracing decoder
        peak, error = allocated(lambda cls=cls: refused(cls))
        assert 'cannot fit' in str(error) or 'ends too early' in str(error)
        assert peak < 64 * 1024, type_name


def test_the_readme_claims_only_what_holds() -> None:
    readme = (Path(__file__).resolve().parents[2] / 'README.md').read_text(encoding='utf-8')
    assert 'allocates more than the input' not in readme  # false for sequences of messages
    assert 'views of the input' in readme and 'std_msgs/String[]' in readme
