"""WebSocket frames as the Foxglove front sees the server's: delimited by their headers only
(the server's frames are unmasked), never parsed further.

A frame is ``data[start:end_of_frame(data, start, end)]``; the front drops only message data frames
(:func:`droppable`) and writes its own warnings as text frames (:func:`status_frame`).
"""

from __future__ import annotations

import json

OP_BINARY = 0x2  #: the WebSocket opcode of a binary frame
MESSAGE_DATA = 1  #: the Foxglove protocol's binary opcode of a message


def status_frame(text: str) -> bytes:
    """A Foxglove warning status as a server's text frame."""
    payload = json.dumps({'op': 'status', 'level': 1, 'message': text, 'id': 'zros.slow'}).encode()
    size = len(payload)
    if size < 126:
        return bytes((0x81, size)) + payload
    return bytes((0x81, 126)) + size.to_bytes(2, 'big') + payload


def end_of_frame(data: bytearray | memoryview, start: int, end: int) -> int:
    """Where the frame at ``start`` ends; -1 when ``data[start:end]`` does not hold its
    header yet."""
    if end - start < 2:
        return -1
    size = data[start + 1] & 0x7F
    if size < 126:
        return start + 2 + size
    if size == 126:
        if end - start < 4:
            return -1
        return start + 4 + int.from_bytes(data[start + 2 : start + 4], 'big')
    if end - start < 10:
        return -1
    return start + 10 + int.from_bytes(data[start + 2 : start + 10], 'big')


def whole_frames(data: bytearray, start: int, end: int) -> tuple[int, int]:
    """Where the whole frames from ``start`` on end in ``data[:end]``, and where the frame
    after them ends (-1: its header is not whole yet).

    A run of frames of one size (a topic of fixed-size messages) is skipped at C speed: from
    a frame's start, the frames after it have the same size as long as their headers repeat
    the same bytes at the same stride (a 2 or 4 byte header: length under 64 KiB)."""
    position = start
    while True:
        frame_end = end_of_frame(data, position, end)
        if frame_end < 0 or frame_end > end:
            return position, frame_end
        stride = frame_end - position
        size = data[position + 1] & 0x7F
        count = (end - position) // stride
        if size == 127 or count < 4:
            position = frame_end
            continue
        header = 2 if size < 126 else 4
        stop = position + count * stride
        same = count
        for offset in range(header):
            column = data[position + offset : stop : stride]
            same = min(same, count - len(column.lstrip(column[:1])))
        position += same * stride


def droppable(frame: bytearray | bytes | memoryview) -> bool:
    """Whether a whole frame is message data (binary, final, Foxglove opcode 1)."""
    first = frame[0]
    if first != 0x80 | OP_BINARY:
        return False
    size = frame[1] & 0x7F
    offset = 2 if size < 126 else 4 if size == 126 else 10
    return len(frame) > offset and frame[offset] == MESSAGE_DATA
