"""zros encodes every rosbags store type byte for byte like rosbags, and round-trips it."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.cdr.rosbags_convert import to_rosbags
from tests.cdr.strategies import message_strategy
from zros.cdr import decode, encode
from zros.cdr.registry import TypeRegistry

REGISTRIES = {distro: TypeRegistry(distro, ament=False) for distro in ('jazzy', 'humble')}
CASES = [
    (distro, name)
    for distro, registry in REGISTRIES.items()
    for name in sorted(registry.typestore.fielddefs)
]


@pytest.mark.parametrize(('distro', 'name'), CASES, ids=[f'{d}:{n}' for d, n in CASES])
@settings(
    max_examples=15,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(data=st.data())
def test_encode_matches_rosbags_and_round_trips(distro: str, name: str, data: Any) -> None:
    registry = REGISTRIES[distro]
    message = data.draw(message_strategy(registry, name, signed_byte_range=True))
    encoded = encode(message)
    expected = registry.typestore.serialize_cdr(
        to_rosbags(registry, registry.typestore, message), name
    ).tobytes()
    assert encoded == expected
    cls = registry.get_class(name)
    assert decode(cls, encoded) == message
    assert decode(cls, bytearray(encoded)) == message
    assert decode(cls, memoryview(encoded)) == message


@pytest.mark.parametrize(
    'name', ['sensor_msgs/msg/Imu', 'geometry_msgs/msg/PoseArray', 'std_msgs/msg/String']
)
@settings(max_examples=20, deadline=None)
@given(data=st.data())
def test_big_endian_input_decodes(name: str, data: Any) -> None:
    registry = REGISTRIES['jazzy']
    message = data.draw(message_strategy(registry, name, signed_byte_range=True))
    rosbags_message = to_rosbags(registry, registry.typestore, message)
    big = registry.typestore.serialize_cdr(rosbags_message, name, little_endian=False).tobytes()
    assert big[:2] == b'\x00\x00'
    decoded = decode(registry.get_class(name), big)
    assert decoded == message
    assert encode(decoded) == encode(message)
