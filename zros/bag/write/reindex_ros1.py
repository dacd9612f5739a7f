"""``zros bag reindex`` of a ROS 1 bag: rewrite it from what can be read.

A ROS 1 bag cut short has lost its index (at the end of the file) and a damaged one has chunks
or records that no longer read: rosbags refuses the first and stops at the second. The bag is
read as :mod:`zros.bag.read.rosbag1_scan` reads it (chunk by chunk, or record by record without
index), and every message that reads is written into a new bag with its connections, chunk
compression and index; the rest is counted. As for MCAP files, the new bag is written beside
the original (``.<name>.reindex``) and renamed over it once complete and on disk, the original
kept as ``NAME.orig.bag`` when asked; a bag that reads whole is left untouched, and one of which
no message reads though it holds some is refused (left as it is).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.errors import BagError
from zros.bag.read.rosbag1 import ros1_typestore
from zros.bag.read.rosbag1_scan import ScannedBag1, indexed_messages, why
from zros.bag.read.source_base import describe_error
from zros.bag.write.replace import lost_words, replacing, temporary_of

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.rosbag1 import Reader

    from zros.bag.read.rosbag1_index import IndexedBag1


class _Readable:
    """A ROS 1 bag opened for reindexing: by rosbags where its index reads, else scanned."""

    def __init__(self, path: Path) -> None:
        from zros.bag.read.rosbag1_index import IndexedBag1  # noqa: PLC0415 (lazy: rosbags, import time)

        self.losses: list[tuple[int, dict[int, int], str]] = []
        self.indexed: IndexedBag1 | None = IndexedBag1(path)
        self.scanned: ScannedBag1 | None = None
        self.compression = 'none'
        try:
            self.indexed.open()
        except Exception:  # cut short, a damaged index: read its records
            self.indexed = None
            self.scanned = ScannedBag1(path)
            self.scanned.open()
            self.losses += self.scanned.losses
            self.compression = self.scanned.compression
        else:
            self.compression = _compression(self.indexed)

    @property
    def connections(self) -> list[Connection]:
        """The connections that were read."""
        reader = self.indexed if self.indexed is not None else self.scanned
        assert reader is not None
        return list(reader.connections)

    def messages(self) -> Iterator[tuple[Connection, int, bytes]]:
        """Every message that reads and converts as the reader converts it, in time order
        (losses are added to ``losses``): the rewritten bag reads whole."""
        reader: IndexedBag1 | ScannedBag1
        if self.scanned is not None:
            reader = self.scanned
            found = self.scanned.messages()
        else:
            assert self.indexed is not None
            reader = self.indexed
            found = indexed_messages(
                self.indexed,
                self.indexed.connections,
                None,
                None,
                lambda offset, lost, why: self.losses.append((offset, lost, why)),
            )
        store, broken = ros1_typestore(self.connections)  # a broken type's messages are kept
        for connection, stamp, data in found:
            if connection.id not in broken:
                try:
                    store.ros1_to_cdr(data, connection.msgtype)
                except Exception as exc:  # flipped bytes in the message: anything from rosbags
                    reason = f'the message at {stamp} does not convert: {why(exc)}'
                    self.losses.append((reader.position, {connection.id: 1}, reason))
                    continue
            yield connection, stamp, data

    def close(self) -> None:
        if self.indexed is not None:
            self.indexed.close()


def _compression(reader: Reader) -> str:
    from rosbags.rosbag1.reader import decompressors  # noqa: PLC0415 (lazy: rosbags, import time)

    for chunk in reader.chunks.values():
        for name, function in decompressors.items():
            if chunk.decompressor is function:
                return name
        break
    return 'none'


@dataclass(frozen=True)
class Rebuilt:
    """What :func:`reindex_ros1` did (``action``: ``'complete'``, everything read,
    ``'rewritten'`` or ``'refused'``, nothing read), the messages the bag holds now, those it
    could not keep (-1: unknown), where the damage was and the name the original is kept
    under."""

    action: str
    message_count: int
    reason: str = ''
    lost_messages: int = 0
    damaged: tuple[int, ...] = ()
    backup: str = ''


def reindex_ros1(file: Path, backup: Path | None = None) -> Rebuilt:
    """Rewrite a ROS 1 bag from what can be read (untouched when everything reads or
    nothing does), keeping the original as ``backup``."""
    try:
        bag = _Readable(file)
    except Exception as exc:  # not even a bag header: nothing to rebuild from
        raise BagError(file, f'cannot read it as a ROS 1 bag: {describe_error(exc)}') from exc
    try:
        count = sum(1 for _ in bag.messages())
        if bag.indexed is not None and not bag.losses:
            return Rebuilt('complete', count)
        counts = [sum(lost.values()) if -1 not in lost else -1 for _, lost, _ in bag.losses]
        lost = -1 if -1 in counts else sum(counts)
        damaged = tuple(dict.fromkeys(offset for offset, _, _ in bag.losses))
        if not count:
            at = ', '.join(map(str, damaged))
            return Rebuilt('refused', 0, f'{lost_words(lost)} damaged or cut short at byte {at}')
        _rewrite(file, bag, backup)
    finally:
        bag.close()
    return Rebuilt(
        'rewritten',
        count,
        '' if bag.indexed is not None else 'its index is gone or damaged',
        lost,
        damaged,
        backup.name if backup is not None else '',
    )


def _rewrite(file: Path, bag: _Readable, backup: Path | None) -> None:
    from rosbags.rosbag1 import Writer  # noqa: PLC0415 (lazy: rosbags, import time)

    temporary_of(file).unlink(missing_ok=True)  # left by a reindex itself interrupted
    with replacing(file, backup) as temporary:
        writer = Writer(temporary)
        if bag.compression != 'none':
            writer.set_compression(Writer.CompressionFormat[bag.compression.upper()])
        with writer:
            written: dict[int, Connection] = {}
            same: dict[tuple[object, ...], Connection] = {}  # rosbags refuses a duplicate
            for connection in bag.connections:
                ext = connection.ext
                key = (
                    connection.topic,
                    connection.msgtype,
                    connection.msgdef.data,
                    connection.digest or '*',
                    getattr(ext, 'callerid', None),
                    getattr(ext, 'latching', None),
                )
                if key not in same:
                    topic, msgtype, msgdef, md5sum, callerid, latching = key
                    same[key] = writer.add_connection(
                        str(topic),
                        str(msgtype),
                        msgdef=str(msgdef),
                        md5sum=str(md5sum),
                        callerid=callerid if isinstance(callerid, str) else None,
                        latching=latching if isinstance(latching, int) else None,
                    )
                written[connection.id] = same[key]
            losses = len(bag.losses)
            for connection, stamp, data in bag.messages():
                writer.write(written[connection.id], stamp, data)
            del bag.losses[losses:]  # the second pass meets the same damage
