"""XXH3-128 (seed 0, default secret) in pure Python, for rmw_zenoh entity GIDs.

rmw_zenoh derives each entity's 16-byte GID from its liveliness token with XXH3-128; zros needs
the same bytes without a compiled dependency. Tokens are short (under 1 KiB), so speed does not
matter here. Written from the published XXH3 algorithm description (xxHash 0.8).
"""

from __future__ import annotations

_M64 = (1 << 64) - 1
_P32_1 = 0x9E3779B1
_P32_2 = 0x85EBCA77
_P32_3 = 0xC2B2AE3D
_P64_1 = 0x9E3779B185EBCA87
_P64_2 = 0xC2B2AE3D27D4EB4F
_P64_3 = 0x165667B19E3779F9
_P64_4 = 0x85EBCA77C2B2AE63
_P64_5 = 0x27D4EB2F165667C5
_MX1 = 0x165667919E3779F9
_MX2 = 0x9FB21C651E98DF25

#: the 192-byte default secret of XXH3
_SECRET = bytes.fromhex(
    'b8fe6c3923a44bbe7c01812cf721ad1cded46de9839097db7240a4a4b7b3671f'
    'cb79e64eccc0e578825ad07dccff7221b8084674f743248ee03590e6813a264c'
    '3c2852bb91c300cb88d0658b1b532ea371644897a20df94e3819ef46a9deacd8'
    'a8fa763fe39c343ff9dcbbc7c70b4f1d8a51e04bcdb45931c89f7ec9d9787364'
    'eac5ac8334d3ebc3c581a0fffa1363eb170ddd51b7f0da49d316552629d4689e'
    '2b16be587d47a1fc8ff8b8d17ad031ce45cb3a8f95160428afd7fbcabb4b407e'
)
_STRIPE = 64
_BLOCK = 1024  # 16 stripes per block with a 192-byte secret


def _r64(data: bytes, offset: int) -> int:
    return int.from_bytes(data[offset : offset + 8], 'little')


def _r32(data: bytes, offset: int) -> int:
    return int.from_bytes(data[offset : offset + 4], 'little')


def _fold(a: int, b: int) -> int:
    product = a * b
    return (product & _M64) ^ (product >> 64)


def _avalanche64(h: int) -> int:
    h ^= h >> 33
    h = (h * _P64_2) & _M64
    h ^= h >> 29
    h = (h * _P64_3) & _M64
    return h ^ (h >> 32)


def _avalanche(h: int) -> int:
    h ^= h >> 37
    h = (h * _MX1) & _M64
    return h ^ (h >> 32)


def _mix16(data: bytes, offset: int, secret_offset: int) -> int:
    low = _r64(data, offset) ^ _r64(_SECRET, secret_offset)
    high = _r64(data, offset + 8) ^ _r64(_SECRET, secret_offset + 8)
    return _fold(low, high)


def _mix32(acc: tuple[int, int], data: bytes, a: int, b: int, secret: int) -> tuple[int, int]:
    low, high = acc
    low = (low + _mix16(data, a, secret)) & _M64
    low ^= (_r64(data, b) + _r64(data, b + 8)) & _M64
    high = (high + _mix16(data, b, secret + 16)) & _M64
    high ^= (_r64(data, a) + _r64(data, a + 8)) & _M64
    return low, high


def _finish(acc: tuple[int, int], length: int) -> tuple[int, int]:
    low, high = acc
    h_low = (low + high) & _M64
    h_high = (low * _P64_1 + high * _P64_4 + length * _P64_2) & _M64
    return _avalanche(h_low), (-_avalanche(h_high)) & _M64


def _short(data: bytes) -> tuple[int, int]:
    length = len(data)
    if length > 8:
        flip_low = _r64(_SECRET, 32) ^ _r64(_SECRET, 40)
        flip_high = _r64(_SECRET, 48) ^ _r64(_SECRET, 56)
        in_low, in_high = _r64(data, 0), _r64(data, length - 8)
        m = (in_low ^ in_high ^ flip_low) * _P64_1
        m_low, m_high = m & _M64, m >> 64
        m_low = (m_low + ((length - 1) << 54)) & _M64
        in_high ^= flip_high
        m_high = (m_high + in_high + (in_high & 0xFFFFFFFF) * (_P32_2 - 1)) & _M64
        m_low ^= int.from_bytes(m_high.to_bytes(8, 'little'), 'big')
        h = m_low * _P64_2
        h_low, h_high = h & _M64, ((h >> 64) + m_high * _P64_2) & _M64
        return _avalanche(h_low), _avalanche(h_high)
    if length >= 4:
        in64 = _r32(data, 0) + (_r32(data, length - 4) << 32)
        keyed = in64 ^ (_r64(_SECRET, 16) ^ _r64(_SECRET, 24))
        m = keyed * (_P64_1 + (length << 2))
        m_low, m_high = m & _M64, m >> 64
        m_high = (m_high + (m_low << 1)) & _M64
        m_low ^= m_high >> 3
        m_low ^= m_low >> 35
        m_low = (m_low * _MX2) & _M64
        m_low ^= m_low >> 28
        return m_low, _avalanche(m_high)
    if length:
        combined = (data[0] << 16) | (data[length >> 1] << 24) | data[-1] | (length << 8)
        swapped = int.from_bytes(combined.to_bytes(4, 'little'), 'big')
        rotated = ((swapped << 13) | (swapped >> 19)) & 0xFFFFFFFF
        flip_low = _r32(_SECRET, 0) ^ _r32(_SECRET, 4)
        flip_high = _r32(_SECRET, 8) ^ _r32(_SECRET, 12)
        return _avalanche64(combined ^ flip_low), _avalanche64(rotated ^ flip_high)
    return (
        _avalanche64(_r64(_SECRET, 64) ^ _r64(_SECRET, 72)),
        _avalanche64(_r64(_SECRET, 80) ^ _r64(_SECRET, 88)),
    )


def _medium(data: bytes) -> tuple[int, int]:
    length = len(data)
    acc = ((length * _P64_1) & _M64, 0)
    if length > 32:
        if length > 64:
            if length > 96:
                acc = _mix32(acc, data, 48, length - 64, 96)
            acc = _mix32(acc, data, 32, length - 48, 64)
        acc = _mix32(acc, data, 16, length - 32, 32)
    acc = _mix32(acc, data, 0, length - 16, 0)
    return _finish(acc, length)


def _large(data: bytes) -> tuple[int, int]:
    length = len(data)
    acc = ((length * _P64_1) & _M64, 0)
    for i in range(4):
        acc = _mix32(acc, data, 32 * i, 32 * i + 16, 32 * i)
    acc = (_avalanche(acc[0]), _avalanche(acc[1]))
    for i in range(4, length // 32):
        acc = _mix32(acc, data, 32 * i, 32 * i + 16, 3 + 32 * (i - 4))
    acc = _mix32(acc, data, length - 16, length - 32, 136 - 17 - 16)
    return _finish(acc, length)


def _accumulate(acc: list[int], data: bytes, offset: int, secret: int) -> None:
    for i in range(8):
        value = _r64(data, offset + 8 * i)
        key = value ^ _r64(_SECRET, secret + 8 * i)
        acc[i ^ 1] = (acc[i ^ 1] + value) & _M64
        acc[i] = (acc[i] + (key & 0xFFFFFFFF) * (key >> 32)) & _M64


def _scramble(acc: list[int]) -> None:
    for i in range(8):
        value = acc[i]
        value ^= value >> 47
        value ^= _r64(_SECRET, len(_SECRET) - _STRIPE + 8 * i)
        acc[i] = (value * _P32_1) & _M64


def _merge(acc: list[int], secret: int, start: int) -> int:
    result = start
    for i in range(4):
        result += _fold(
            acc[2 * i] ^ _r64(_SECRET, secret + 16 * i),
            acc[2 * i + 1] ^ _r64(_SECRET, secret + 16 * i + 8),
        )
    return _avalanche(result & _M64)


def _long(data: bytes) -> tuple[int, int]:
    length = len(data)
    acc = [_P32_3, _P64_1, _P64_2, _P64_3, _P64_4, _P32_2, _P64_5, _P32_1]
    blocks = (length - 1) // _BLOCK
    for block in range(blocks):
        for stripe in range(16):
            _accumulate(acc, data, block * _BLOCK + stripe * _STRIPE, stripe * 8)
        _scramble(acc)
    stripes = ((length - 1) - blocks * _BLOCK) // _STRIPE
    for stripe in range(stripes):
        _accumulate(acc, data, blocks * _BLOCK + stripe * _STRIPE, stripe * 8)
    _accumulate(acc, data, length - _STRIPE, len(_SECRET) - _STRIPE - 7)
    low = _merge(acc, 11, (length * _P64_1) & _M64)
    high = _merge(acc, len(_SECRET) - 64 - 11, ~(length * _P64_2) & _M64)
    return low, high


def xxh3_128(data: bytes) -> tuple[int, int]:
    """The XXH3-128 hash of ``data`` as ``(low64, high64)``."""
    if len(data) <= 16:
        return _short(data)
    if len(data) <= 128:
        return _medium(data)
    if len(data) <= 240:
        return _large(data)
    return _long(data)


def xxh3_128_digest(data: bytes) -> bytes:
    """The canonical 16-byte digest (big-endian ``high64`` then ``low64``), as xxhash gives."""
    low, high = xxh3_128(data)
    return high.to_bytes(8, 'big') + low.to_bytes(8, 'big')
