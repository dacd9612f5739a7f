"""The whole records at the start of an MCAP chunk that the end of the file cuts short (a copy
of a file still being written, a full disk, a download cut off).

A chunk's CRC covers all of its records, so none of a cut chunk's can be checked: the records
are read up to the first sign of damage (a record that does not parse, a message outside the
chunk's declared times, more output than declared). The compressed bytes present are
decompressed as a stream (zstd and lz4 frames give their output so far) and parsed up to the
last whole record, a piece at a time: memory holds at most the chunk's records, never the
file. :func:`intact_start` reads a whole chunk that fails its CRC or does not decompress the
same way (the start before the damage); its readers keep only the messages its message index
confirms.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, BinaryIO

if TYPE_CHECKING:
    from mcap.records import Chunk

if TYPE_CHECKING:
    from mcap.records import McapRecord

#: a chunk record's opcode, and the byte lengths of its fields before the compression name
CHUNK_OPCODE = 0x06
CHUNK_HEAD = struct.Struct('<BQQQQII')
COMPRESSIONS = (b'', b'lz4', b'zstd')
#: opcode and length, before every record
RECORD = struct.Struct('<BQ')
_SCHEMA, _CHANNEL, _MESSAGE = 0x03, 0x04, 0x05
#: the compressed bytes read and decompressed at a time
_PIECE = 1 << 16
#: the zstd output taken at a time (what precedes an error in the same take is lost)
_OUTPUT = 1 << 12


@dataclass
class CutChunk:
    """A chunk record at byte ``at`` whose declared end lies past the end of the file (its
    ``size``). ``data_at`` is None when the file ends inside its header; ``messages`` and
    ``damage`` say what reading it found."""

    at: int
    size: int
    length: int | None = None  #: the record's declared length (None: not even that present)
    first: int = 0  #: its messages' first and last log times, as its header declares
    last: int = 0
    uncompressed: int = 0
    compression: str = ''
    data_at: int | None = None
    data_length: int = 0
    messages: int = 0
    damage: str = ''
    whole: int = 0  #: the uncompressed bytes of the whole records read (the intact start)
    last_record: int = 0  #: where the last of them starts
    produced: int = 0  #: the uncompressed bytes decompressed (before an error)

    def describe(self) -> str:
        """Why the scan stops here, and what of the chunk was read: a sentence for a user."""
        if self.data_at is None or self.length is None:
            return (
                f'the file ends at byte {self.size}, inside the header of the chunk at byte '
                f'{self.at}: that chunk is lost'
            )
        total = RECORD.size + self.length
        return describe_cut(self.at, self.size, total, self.messages, self.damage)


def describe_cut(at: int, size: int, total: int, messages: int, damage: str) -> str:
    """A sentence for a user: the file ends at byte ``size`` inside the chunk record of
    ``total`` bytes at byte ``at``, of which ``messages`` were read (``damage``: why the read
    of its part stopped before that part's end)."""
    text = (
        f'the file ends at byte {size}, inside the chunk at byte {at} '
        f'({size - at} of its {total} bytes present)'
    )
    if messages == 1:
        text += ': its first message was read, the rest of it is lost'
    elif messages:
        text += f': its first {messages} messages were read, the rest of it is lost'
    else:
        text += ': no whole message in the part present, that chunk is lost'
    return f'{text} ({damage})' if damage else text


def cut_chunk(stream: BinaryIO, at: int, size: int) -> CutChunk | None:
    """The chunk at byte ``at`` when the file's end (at ``size``) cuts it short; None when the
    record there is not a chunk, or is one whose lengths do not add up (damaged, not cut)."""
    stream.seek(at)
    head = stream.read(CHUNK_HEAD.size + 4 + 8)  # the longest compression name, then a length
    if not head or head[0] != CHUNK_OPCODE:
        return None
    if len(head) < RECORD.size:
        return CutChunk(at, size)
    _, length = RECORD.unpack_from(head)
    if at + RECORD.size + length <= size:
        return None
    if len(head) < CHUNK_HEAD.size:
        return CutChunk(at, size, length)
    _, _, first, last, uncompressed, _, name_length = CHUNK_HEAD.unpack_from(head)
    if name_length > 4:
        return None
    records_at = CHUNK_HEAD.size + name_length
    if len(head) < records_at + 8:
        return CutChunk(at, size, length)
    name = head[CHUNK_HEAD.size : records_at]
    (records_length,) = struct.unpack_from('<Q', head, records_at)
    if name not in COMPRESSIONS or records_at + 8 + records_length != RECORD.size + length:
        return None
    return CutChunk(
        at,
        size,
        length,
        first,
        last,
        uncompressed,
        name.decode(),
        at + records_at + 8,
        records_length,
    )


def read_cut(stream: BinaryIO, chunk: CutChunk) -> Iterator[McapRecord]:
    """The whole Schema, Channel and Message records in the part of ``chunk`` present, in
    order; counts its messages into ``chunk.messages`` and stops at the first sign of damage
    (in ``chunk.damage``)."""
    if chunk.data_at is None:
        return
    buffer = bytearray()
    produced = 0  # the uncompressed bytes so far
    stream.seek(chunk.data_at)
    pieces = _decompressed(stream, chunk.compression)
    while not chunk.damage:
        try:
            piece = next(pieces, b'')
        except Exception as exc:  # zstd's or lz4's error on a damaged frame, or none installed
            chunk.damage = f'it does not decompress further: {str(exc) or type(exc).__name__}'
            return
        if not piece:
            return
        produced += len(piece)
        chunk.produced = produced
        if produced > chunk.uncompressed:
            chunk.damage = 'it decompresses to more than its header declares'
            return
        buffer += piece
        yield from _whole(buffer, chunk)


def _decompressed(stream: BinaryIO, compression: str) -> Iterator[bytes]:
    """The output of the compressed bytes from the position of ``stream`` to the file's end
    (the chunk's part present), as far as they go, in pieces of at most :data:`_PIECE`."""
    if compression == 'zstd':
        import zstandard  # noqa: PLC0415 (only for zstd chunks)

        reader = zstandard.ZstdDecompressor().stream_reader(stream, read_size=_PIECE, closefd=False)
        while piece := reader.read(_OUTPUT):
            yield piece
    elif compression == 'lz4':
        import lz4.frame  # type: ignore[import-untyped]  # noqa: PLC0415 (only for lz4 chunks)

        decompressor = lz4.frame.LZ4FrameDecompressor()
        while data := stream.read(_PIECE):
            while True:  # at most a piece of output at a time
                output: bytes = decompressor.decompress(data, max_length=_PIECE)
                if output:
                    yield output
                data = b''
                if decompressor.needs_input or decompressor.eof:
                    break
    else:
        while piece := stream.read(_PIECE):
            yield piece


def _whole(buffer: bytearray, chunk: CutChunk) -> Iterator[McapRecord]:
    """The whole records at the start of ``buffer``, removed from it."""
    records = []
    done = 0
    while len(buffer) - done >= RECORD.size:
        opcode, length = RECORD.unpack_from(buffer, done)
        if RECORD.size + length > chunk.uncompressed:  # else held until it never completes
            chunk.damage = 'a record in it is longer than the chunk'
            break
        end = done + RECORD.size + length
        if end > len(buffer):
            break
        if opcode == 0:  # no record has it: zeroed bytes
            chunk.damage = 'a record in it has opcode 0'
            break
        record = _record(opcode, bytes(buffer[done + RECORD.size : end]), chunk)
        if chunk.damage:
            break
        chunk.last_record = chunk.whole + done
        done = end
        if record is not None:
            records.append(record)
    del buffer[:done]
    chunk.whole += done
    yield from records


def _record(opcode: int, body: bytes, chunk: CutChunk) -> McapRecord | None:
    """A Schema, Channel or Message record from its body (None for other records); damage
    noted in ``chunk`` when it does not parse or a message lies outside the chunk's times."""
    from mcap.data_stream import ReadDataStream  # noqa: PLC0415 (lazy: mcap, import time)
    from mcap.records import Channel, Message, Schema  # noqa: PLC0415 (lazy: mcap, import time)

    stream = ReadDataStream(io.BytesIO(body))
    record: McapRecord | None = None
    try:
        if opcode == _SCHEMA:
            record = Schema.read(stream)
        elif opcode == _CHANNEL:
            record = Channel.read(stream)
        if opcode != _MESSAGE:
            return record
        message = Message.read(stream, len(body)) if len(body) >= 22 else None
    except Exception as exc:  # the mcap library's parse errors: struct, unicode, end of data
        chunk.damage = f'a record in it does not parse: {str(exc) or type(exc).__name__}'
        return None
    if message is None or (chunk.last and not chunk.first <= message.log_time <= chunk.last):
        chunk.damage = 'a message in it is not one its header declares'
        return None
    chunk.messages += 1
    record = message
    return record


def intact_start(at: int, record: Chunk) -> tuple[CutChunk, list[McapRecord], bytes]:
    """The start of a whole chunk record at byte ``at`` that fails its CRC or does not
    decompress: the chunk read as a cut one (its ``damage`` says where the read stopped), the
    records that can be trusted, and their uncompressed bytes (offsets as in the chunk).

    Damage can read as plausible records before the read notices it (zeroed payloads, a
    compressed block decoding to garbage), so only what lies before where it is located is
    trusted: an uncompressed chunk's records before the last one the parse stopped after, a
    compressed chunk's output before the block its decompressor failed in and the one before
    (nothing when it decompressed whole, or only its checksum failed: no place is known).
    """
    chunk = CutChunk(
        at,
        0,
        len(record.data),
        record.message_start_time,
        record.message_end_time,
        record.uncompressed_size,
        record.compression,
        0,
        len(record.data),
    )
    if record.compression.encode() not in COMPRESSIONS:
        chunk.damage = f'compression {record.compression!r} unknown'
        return chunk, [], b''
    records = list(read_cut(io.BytesIO(record.data), chunk))  # memory: one chunk
    start = bytearray()
    pieces = _decompressed(io.BytesIO(record.data), chunk.compression)
    while len(start) < chunk.whole:
        start += next(pieces)  # it gave as much before
    trusted = _trusted(record, chunk)
    kept = 0
    done = 0
    while done + RECORD.size <= chunk.whole:  # the whole records before ``trusted``
        opcode, length = RECORD.unpack_from(start, done)
        if done + RECORD.size + length > trusted:
            break
        done += RECORD.size + length
        kept += opcode in (_SCHEMA, _CHANNEL, _MESSAGE)
    chunk.whole = done
    return chunk, records[:kept], bytes(start[:done])


def read_part(chunk: CutChunk) -> str:
    """What of a damaged chunk :func:`intact_start` read, for a user (the same whichever
    messages of it a read wants: damage is reported once)."""
    if not chunk.whole:
        return 'nothing of it before the damage can be trusted'
    return (
        f'its messages in its first {chunk.whole} of {chunk.uncompressed} bytes (uncompressed) '
        'that its index confirms were read'
    )


def _trusted(record: Chunk, chunk: CutChunk) -> int:
    """The uncompressed bytes of a damaged chunk before where its damage is known to lie."""
    if not record.compression:
        return chunk.last_record if chunk.damage else 0
    if not chunk.damage.startswith('it does not decompress') or 'checksum' in chunk.damage:
        return 0
    if record.compression == 'zstd':
        block = 1 << 17
    else:  # lz4: the frame's block size, from its descriptor
        block = 1 << (8 + 2 * ((record.data[5] >> 4) & 7)) if len(record.data) > 5 else 0
    return max(0, chunk.produced - 2 * block)
