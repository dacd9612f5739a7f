"""The attachment rmw_zenoh puts on every publication, request and reply.

Current format (rmw_zenoh Jazzy >= 0.2.4, Kilted, Humble >= 0.1.2; spec §4.1), 33 bytes::

    int64 LE sequence number | int64 LE source timestamp (ns) | 0x10 | 16-byte GID

Readers also accept the legacy 77-byte form (spec §4.2), where each value follows its name.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from zros.keyexpr.errors import AttachmentError

SIZE = 33
GID_SIZE = 16
_HEAD = struct.Struct('<qqB')
_INT64 = struct.Struct('<q')
_LEGACY_NAMES = (b'sequence_number', b'source_timestamp', b'source_gid')
LEGACY_SIZE = 77


@dataclass(frozen=True)
class Attachment:
    """Sequence number, source timestamp (ns since the epoch) and the 16-byte GID of a sender."""

    sequence_number: int
    source_timestamp: int
    gid: bytes

    def __post_init__(self) -> None:
        if len(self.gid) != GID_SIZE:
            raise AttachmentError(f'a GID has {GID_SIZE} bytes, not {len(self.gid)}')
        for name in ('sequence_number', 'source_timestamp'):
            if not -(2**63) <= getattr(self, name) < 2**63:
                raise AttachmentError(f'{name} does not fit in an int64')

    def encode(self) -> bytes:
        """The 33 bytes rmw_zenoh writes."""
        head = _HEAD.pack(self.sequence_number, self.source_timestamp, GID_SIZE)
        return head + bytes(self.gid)

    def encode_legacy(self) -> bytes:
        """The 77-byte form of rmw_zenoh before the change to plain fields (#601)."""
        values = (
            _INT64.pack(self.sequence_number),
            _INT64.pack(self.source_timestamp),
            bytes([GID_SIZE]) + bytes(self.gid),
        )
        return b''.join(bytes([len(n)]) + n + v for n, v in zip(_LEGACY_NAMES, values, strict=True))

    @classmethod
    def decode(cls, data: bytes) -> Attachment:
        """Read a 33-byte (or legacy 77-byte) attachment; AttachmentError otherwise."""
        data = bytes(data)
        if len(data) == SIZE:
            sequence, stamp, size = _HEAD.unpack_from(data)
            if size != GID_SIZE:
                raise AttachmentError(f'the GID length byte is {size}, not {GID_SIZE}')
            return cls(sequence, stamp, data[_HEAD.size :])
        if len(data) == LEGACY_SIZE and data[0] == len(_LEGACY_NAMES[0]):
            return cls._decode_legacy(data)
        raise AttachmentError(f'an rmw_zenoh attachment has {SIZE} bytes, not {len(data)}')

    @classmethod
    def _decode_legacy(cls, data: bytes) -> Attachment:
        offset = 0
        values: list[bytes] = []
        for name, size in zip(_LEGACY_NAMES, (8, 8, 1 + GID_SIZE), strict=True):
            end = offset + 1 + len(name)
            if data[offset] != len(name) or data[offset + 1 : end] != name:
                raise AttachmentError(f'a legacy attachment lacks the field {name.decode()}')
            values.append(data[end : end + size])
            offset = end + size
        if values[2][0] != GID_SIZE:
            raise AttachmentError(f'the GID length byte is {values[2][0]}, not {GID_SIZE}')
        return cls(_INT64.unpack(values[0])[0], _INT64.unpack(values[1])[0], values[2][1:])
