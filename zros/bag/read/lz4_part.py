"""What the start of an LZ4 frame cut short decompresses to.

The lz4 library gives nothing of a block until the whole block is present, and ROS 1 writes a
chunk as one frame of blocks of up to 1 MB (``tf_example.bag``: one block), so a chunk the
file's end cuts short would give nothing. An LZ4 block is a run of sequences (literals, then
a copy of earlier output), each decodable once its bytes are present: this decoder goes block
by block and, in the last block present, sequence by sequence up to the end of the data. Pure
Python: a chunk (under a megabyte) at a time, once, when a file is cut short.
"""

from __future__ import annotations

import struct

MAGIC = 0x184D2204
_HAS_SIZE, _BLOCK_SUM, _HAS_DICT = 0x08, 0x10, 0x01
_UNCOMPRESSED = 0x80000000
_TOO_MUCH = 'it decompresses to more than its header declares'


def decompress_part(data: bytes, limit: int) -> bytes:
    """The output of the whole sequences in ``data``, an LZ4 frame's first bytes (at most
    ``limit`` bytes of it: more is damage, ValueError, as is a frame that does not parse)."""
    if len(data) < 7 or struct.unpack_from('<I', data)[0] != MAGIC:
        raise ValueError('not an LZ4 frame')
    flags = data[4]
    at = 7 + (8 if flags & _HAS_SIZE else 0) + (4 if flags & _HAS_DICT else 0)
    out = bytearray()
    while at + 4 <= len(data):
        (size,) = struct.unpack_from('<I', data, at)
        at += 4
        if size == 0:  # the end mark
            break
        stored, size = size & _UNCOMPRESSED, size & ~_UNCOMPRESSED
        block = data[at : at + size]
        if stored:
            out += block
        else:
            _decode(block, out, limit)
        if len(out) > limit:
            raise ValueError(_TOO_MUCH)
        at += size + (4 if flags & _BLOCK_SUM else 0)
    return bytes(out)


def _decode(block: bytes, out: bytearray, limit: int) -> None:
    """Append the whole sequences of an LZ4 block (or the first part of one) to ``out``, whose
    end earlier blocks may refer to."""
    at, end = 0, len(block)
    while at < end:
        token = block[at]
        at += 1
        literals, at = _length(block, at, token >> 4)
        if at < 0:
            return
        out += block[at : at + literals]  # literals cut short are still output as written
        at += literals
        if at + 2 > end:
            return
        offset = block[at] | block[at + 1] << 8
        at += 2
        match, at = _length(block, at, token & 0x0F)
        if at < 0:
            return
        match += 4
        start = len(out) - offset
        if offset == 0 or start < 0:
            raise ValueError('an LZ4 sequence in it does not parse')
        if len(out) + match > limit:
            raise ValueError(_TOO_MUCH)
        if offset >= match:
            out += out[start : start + match]
        else:  # the copy overlaps what it writes: a repeating pattern
            pattern = out[start:]
            out += (pattern * (match // offset + 1))[:match]


def _length(block: bytes, at: int, length: int) -> tuple[int, int]:
    """A sequence's length field (the token's 4 bits, 15 followed by bytes): the length and
    the position after it, -1 when the block's end cuts it."""
    if length != 15:
        return length, at
    while True:
        if at >= len(block):
            return 0, -1
        more = block[at]
        at += 1
        length += more
        if more != 255:
            return length, at
