"""What goes on the WebSocket: protocol messages as JSON text or CBOR, ``png`` compression and
``fragment`` messages, as rosbridge_library makes them.

* JSON messages are text frames, CBOR ones (``cbor``, ``cbor-raw``) binary frames.
* ``png``: the JSON text as the pixels of a square-ish RGB image padded with newlines, base64
  in ``{"op": "png", "data": ...}`` (rosbridge's ``pngcompression.encode``).
* A JSON text longer than the fragment size goes as ``{"op": "fragment", "id", "data", "num",
  "total"}`` messages whose ``data`` joined give the text back. They are made one at a time by
  the writer of the client that asked for them (:class:`Fragmented`), so a small fragment size
  costs that client's thread, not the thread delivering the topic to every subscriber.

A :class:`Sample` is one message received on a topic; it encodes itself once per form (JSON,
CBOR, raw CDR, PNG) whatever the number of subscribers that want that form. Its JSON text is
written without the long base64 strings, which are spliced in after (:func:`to_text_with`).
"""

from __future__ import annotations

import base64
import itertools
import json
import json.encoder
import math
import struct
import zlib
from collections.abc import Iterator
from typing import TYPE_CHECKING, TypeAlias

import numpy as np

from zros.cdr import decode
from zros.gateway.rosbridge.conversion import blob_mark

if TYPE_CHECKING:
    from zros.cdr import Message
    from zros.gateway.common.json_types import OutObject
    from zros.gateway.rosbridge.conversion import Values

COMPRESSIONS = ('none', 'png', 'cbor', 'cbor-raw')
_fragment_ids = itertools.count(1)
#: bytes of a fragment message besides its data (its id excepted)
_FRAGMENT_HEAD = len('{"op":"fragment","id":,"data":"","num":,"total":}') + 2 * 8


class Fragmented:
    """A JSON text to send as ``fragment`` messages of ``size`` characters, made one by one as
    they are iterated (the text is shared with every subscriber that wants it whole)."""

    __slots__ = ('_head', 'size', 'text', 'total')

    def __init__(self, text: str, size: int, message_id: object) -> None:
        self.text = text
        self.size = size
        self.total = math.ceil(len(text) / size)
        self._head = f'{{"op":"fragment","id":{to_text(message_id)},"data":'

    def __iter__(self) -> Iterator[str]:
        text, size, head, total = self.text, self.size, self._head, self.total
        # the text is JSON: ASCII, where only quotes and backslashes need escaping again
        escape = json.encoder.encode_basestring_ascii
        for number, start in enumerate(range(0, len(text), size)):
            yield f'{head}{escape(text[start : start + size])},"num":{number},"total":{total}}}'

    @property
    def nbytes(self) -> int:
        """About the bytes its frames take (for the bound of a client's outbox)."""
        return len(self.text) + self.total * (len(self._head) + _FRAGMENT_HEAD)


#: what one protocol message becomes: its frames, sent in order (text or binary)
Frames: TypeAlias = tuple[str | bytes, ...] | Fragmented


def frames_size(frames: Frames) -> int:
    """The bytes ``frames`` take on the wire (about, for fragments)."""
    if isinstance(frames, Fragmented):
        return frames.nbytes
    return sum(len(frame) for frame in frames)


def to_text(message: object) -> str:
    """A protocol message as JSON text (NaN is never written: values carry null instead)."""
    return json.dumps(message, separators=(',', ':'), allow_nan=False)


def to_text_with(message: OutObject, blobs: list[str]) -> str:
    """:func:`to_text` of values holding :func:`blob_mark` marks, with the blobs put in their
    place (in order: the JSON text has the values in the order they were made)."""
    rest = to_text(message)
    pieces: list[str] = []
    for index, blob in enumerate(blobs):
        head, mark, rest = rest.partition(blob_mark(index))
        if not mark:
            raise ValueError(f'blob {index} is missing from the JSON text')
        pieces += (head, blob)
    pieces.append(rest)
    return ''.join(pieces)


def to_cbor(message: OutObject) -> bytes:
    """A protocol message as CBOR."""
    import cbor2  # noqa: PLC0415 (optional: the rosbridge extra)

    return cbor2.dumps(message)


def png_message(text: str) -> str:
    """The ``png`` message carrying ``text``, as rosbridge's ``pngcompression.encode`` packs
    it: the UTF-8 bytes as RGB pixels, width ``floor(sqrt(n / 3))``, padded with ``\\n``."""
    data = text.encode()
    width = max(1, math.floor(math.sqrt(len(data) / 3)))
    height = max(1, math.ceil(len(data) / 3 / width))
    pixels = np.frombuffer(data.ljust(width * height * 3, b'\n'), np.uint8)
    rows = np.zeros((height, 1 + width * 3), np.uint8)  # filter byte 0 (none) per row
    rows[:, 1:] = pixels.reshape(height, width * 3)

    def chunk(kind: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(kind + body) & 0xFFFFFFFF
        return struct.pack('>I', len(body)) + kind + body + struct.pack('>I', crc)

    png = b''.join(
        (
            b'\x89PNG\r\n\x1a\n',
            chunk(b'IHDR', struct.pack('>IIBBBBB', width, height, 8, 2, 0, 0, 0)),
            chunk(b'IDAT', zlib.compress(rows.tobytes(), 6)),
            chunk(b'IEND', b''),
        )
    )
    return to_text({'op': 'png', 'data': base64.b64encode(png).decode('ascii')})


def split(text: str, size: int, message_id: object = None) -> Frames:
    """``text`` as one frame, or as fragment messages of ``size`` characters of it when
    longer (made as they are sent)."""
    if size <= 0 or len(text) <= size:
        return (text,)
    if message_id is None:
        message_id = f'fragment:{next(_fragment_ids)}'
    return Fragmented(text, size, message_id)


def fragments(text: str, size: int, message_id: object = None) -> tuple[str | bytes, ...]:
    """The frames of :func:`split`, made now."""
    return tuple(split(text, size, message_id))


def encode(
    message: OutObject, compression: str = 'none', fragment_size: int | None = None
) -> Frames:
    """The frames of a protocol message whose values are already in rosbridge's shapes."""
    if compression in ('cbor', 'cbor-raw'):
        return (to_cbor(message),)
    text = to_text(message)
    if compression == 'png':
        text = png_message(text)
    return split(text, fragment_size or 0, message.get('id'))


class Sample:
    """One message of a topic on its way to subscribers: the CDR bytes, the time it arrived
    (ns), and its encodings, made on first use."""

    __slots__ = ('_cache', '_message', 'cls', 'data', 'stamp', 'topic', 'values')

    def __init__(
        self, topic: str, cls: type[Message], data: bytes, stamp: int, values: Values
    ) -> None:
        self.topic = topic
        self.cls = cls
        self.data = data
        self.stamp = stamp
        self.values = values
        self._message: Message | None = None
        self._cache: dict[tuple[str, int], Frames] = {}

    def message(self) -> Message:
        """The decoded message (CdrError when the bytes do not decode)."""
        if self._message is None:
            self._message = decode(self.cls, self.data)
        return self._message

    def frames(self, compression: str, fragment_size: int) -> Frames:
        """The ``publish`` message of this sample for a subscription's options."""
        key = (compression, fragment_size if compression in ('none', 'png') else 0)
        found = self._cache.get(key)
        if found is not None:
            return found
        head: OutObject = {'op': 'publish', 'topic': self.topic}
        if compression == 'cbor-raw':
            secs, nsecs = divmod(self.stamp, 1_000_000_000)
            frames: Frames = (
                to_cbor({**head, 'msg': {'secs': secs, 'nsecs': nsecs, 'bytes': self.data}}),
            )
        elif compression == 'cbor':
            frames = (to_cbor({**head, 'msg': self.values.to_cbor(self.message())}),)
        else:
            frames = split(self._text(head, compression == 'png'), fragment_size)
        self._cache[key] = frames
        return frames

    def _text(self, head: OutObject, png: bool) -> str:
        key = ('png' if png else 'json', -1)
        found = self._cache.get(key)
        if isinstance(found, tuple):
            return str(found[0])
        if png:
            text = png_message(self._text(head, False))
        else:
            blobs: list[str] = []
            values = self.values.to_json(self.message(), blobs)
            text = to_text_with({**head, 'msg': values}, blobs)
        self._cache[key] = (text,)
        return text
