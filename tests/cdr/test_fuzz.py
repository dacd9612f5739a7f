"""Mutated and truncated payloads only ever raise CdrError, quickly, for many types."""

from __future__ import annotations

import random
import struct
import time
from typing import Any

import numpy as np

from zros import cdr
from zros.cdr.layout import VALUE_CODES
from zros.cdr.model import INTEGER_RANGES, FieldType, Kind
from zros.cdr.naming import attribute_name
from zros.cdr.registry import TypeRegistry

REGISTRY = TypeRegistry('jazzy', paths=[], ament=False)
REGISTRY.register_text('fuzz_msgs/msg/Wide', 'wstring text\nwstring<=4[] words\nint8 tail')
REGISTRY.register_text(
    'fuzz_msgs/msg/Bounded', 'string<=8 name\nfloat32[<=3] values\nbool[2] flags'
)
TYPES = [name for index, name in enumerate(sorted(REGISTRY.typestore.fielddefs)) if index % 3 == 0]
TYPES += [
    'fuzz_msgs/msg/Wide',
    'fuzz_msgs/msg/Bounded',
    'visualization_msgs/msg/MarkerArray',
    'sensor_msgs/msg/PointCloud2',
    'geometry_msgs/msg/PoseArray',
    'tf2_msgs/msg/TFMessage',
]
TOTAL_PAYLOADS = 100_000
SLOWEST_ALLOWED = 0.25  # seconds for one decode; a hang or a runaway loop would blow it


def _value(rng: random.Random, ftype: FieldType) -> Any:
    if ftype.kind is not Kind.SCALAR:
        count = (
            ftype.length if ftype.kind is Kind.ARRAY else rng.randint(0, min(ftype.length or 3, 3))
        )
        items = [_value(rng, ftype.element) for _ in range(count)]
        if ftype.is_primitive:
            return np.array(items, dtype=VALUE_CODES[ftype.base])
        return items
    if ftype.base == 'bool':
        return rng.random() < 0.5
    if ftype.base in INTEGER_RANGES:
        low, high = INTEGER_RANGES[ftype.base]
        return rng.randint(low, high)
    if ftype.base.startswith('float'):
        return float(np.float32(rng.uniform(-1e3, 1e3)))
    if ftype.is_string:
        if ftype.string_bound:
            return 'x' * rng.randint(0, min(ftype.string_bound, 8))
        return ''.join(rng.choice('abcdé€') for _ in range(rng.randint(0, 6)))
    return _message(rng, ftype.base)


def _message(rng: random.Random, name: str) -> Any:
    definition = REGISTRY.message_definition(name)
    values = {attribute_name(f.name): _value(rng, f.type) for f in definition.fields}
    return REGISTRY.get_class(name)(**values)


def _mutate(rng: random.Random, data: bytes) -> bytes:
    buf = bytearray(data)
    choice = rng.randrange(7)
    if choice == 0 and buf:  # flip bytes
        for _ in range(rng.randint(1, 4)):
            buf[rng.randrange(len(buf))] = rng.randrange(256)
    elif choice == 1:  # truncate
        del buf[rng.randrange(len(buf) + 1) :]
    elif choice == 2 and len(buf) >= 8:  # a length or count field gets a wild value
        offset = 4 + 4 * rng.randrange((len(buf) - 4) // 4)
        wild = rng.choice([0, 1, 2**31, 2**32 - 1, rng.randrange(2**32), len(buf), len(buf) // 2])
        struct.pack_into('<I', buf, offset, wild)
    elif choice == 3:  # insert garbage
        at = rng.randrange(len(buf) + 1)
        buf[at:at] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 9)))
    elif choice == 4 and len(buf) > 4:  # delete a slice
        at = rng.randrange(4, len(buf))
        del buf[at : at + rng.randint(1, 9)]
    elif choice == 5:  # a damaged header
        buf[rng.randrange(min(4, len(buf)) or 1) if buf else 0 : 0] = b''
        if len(buf) >= 2:
            buf[rng.randrange(2)] = rng.randrange(256)
    else:  # random bytes after a valid header
        buf = bytearray(data[:4] + bytes(rng.randrange(256) for _ in range(rng.randint(0, 64))))
    return bytes(buf)


def test_mutated_payloads_raise_only_cdr_errors() -> None:
    rng = random.Random(20261122)
    per_type = -(-TOTAL_PAYLOADS // len(TYPES))
    assert len(TYPES) >= 50
    decoded = failed = 0
    slowest = 0.0
    for name in TYPES:
        cls = REGISTRY.get_class(name)
        seeds = [cdr.encode(cls())] + [cdr.encode(_message(rng, name)) for _ in range(4)]
        for index in range(per_type):
            payload = _mutate(rng, seeds[index % len(seeds)])
            buffer: Any = (
                payload if index % 3 else (bytearray(payload) if index % 2 else memoryview(payload))
            )
            start = time.perf_counter()
            try:
                cdr.decode(cls, buffer)
                decoded += 1
            except cdr.CdrError:
                failed += 1
            except Exception as exc:  # pragma: no cover - a finding
                raise AssertionError(
                    f'{name}: {type(exc).__name__}: {exc} for payload {payload.hex()}'
                ) from exc
            slowest = max(slowest, time.perf_counter() - start)
    assert decoded + failed == per_type * len(TYPES) >= TOTAL_PAYLOADS
    assert failed > decoded / 10  # the mutations really do break payloads
    assert slowest < SLOWEST_ALLOWED, f'one decode took {slowest:.3f} s'
