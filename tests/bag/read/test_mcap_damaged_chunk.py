"""An MCAP chunk damaged in the middle (its CRC fails, or it stops decompressing) keeps the
messages before the damage that its message index confirms, on both read paths (the summary's
chunk index, and the linear scan of a file without summary that reindex uses); the rest are
counted in ``Bag.skipped``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.bag.makebags import make_points_mcap
from tests.bag.read.test_damage import _chunk_messages
from zros.bag import Bag, reindex

Messages = list[tuple[str, int, bytes]]


def _one_damaged_chunk(path: Path, compression: str) -> tuple[int, Messages]:
    """A one-chunk file of 30000 messages, 4 KB zeroed at 60 % of its chunk: the chunk's
    offset and its messages in the chunk's order."""
    from mcap.reader import make_reader

    make_points_mcap(path, 30000, compression, chunk_size=1 << 24, shuffle=False)
    with path.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    [chunk] = summary.chunk_indexes
    in_order = _chunk_messages(path, chunk.chunk_start_offset)
    data = bytearray(path.read_bytes())
    at = chunk.chunk_start_offset + chunk.chunk_length * 6 // 10
    data[at : at + 4096] = bytes(4096)
    path.write_bytes(bytes(data))
    return chunk.chunk_start_offset, in_order


def _read(path: Path) -> tuple[Messages, list[tuple[int | None, int, str]]]:
    with Bag(path) as bag:
        got = [(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()]
        return got, [(s.offset, s.lost, s.reason) for s in bag.skipped]


@pytest.mark.parametrize(
    ('compression', 'why'),
    [
        ('zstd', 'decompression error: Data corruption detected'),
        ('none', 'message index does not match the chunk'),
    ],
)
def test_the_start_of_a_damaged_chunk_is_read(tmp_path: Path, compression: str, why: str) -> None:
    path = tmp_path / 'p.mcap'
    offset, in_order = _one_damaged_chunk(path, compression)
    got, [(at, lost, reason)] = _read(path)
    assert len(in_order) // 3 < len(got) < len(in_order)
    assert got == in_order[: len(got)]  # equal to the intact file's first messages
    assert (at, lost) == (offset, len(in_order) - len(got))
    assert reason.startswith(f'{why}; its messages in its first ')
    assert reason.endswith(' bytes (uncompressed) that its index confirms were read')
    # the linear scan (no summary trusted: reindex) keeps the same
    [report] = reindex(path, backup=False).files
    assert (report.message_count, report.lost_messages) == (len(got), lost)
    assert _read(path) == (got, [])


def test_an_lz4_chunk_of_one_block_keeps_nothing_and_counts_it(tmp_path: Path) -> None:
    # the mcap writer's lz4 frame is one 4 MB block: nothing of it decompresses before the end
    path = tmp_path / 'p.mcap'
    offset, in_order = _one_damaged_chunk(path, 'lz4')
    got, [(at, lost, reason)] = _read(path)
    assert (got, at, lost) == ([], offset, len(in_order))
    assert reason.endswith('; nothing of it before the damage can be trusted')
    [report] = reindex(path).files
    assert report.action == 'refused'


def test_a_chunk_whose_payloads_alone_are_zeroed_keeps_nothing_unconfirmed(
    tmp_path: Path,
) -> None:
    # zeroed in an uncompressed chunk where the parse does not notice it: the CRC (checked by
    # the linear scan) fails, no place is known, so nothing of it is trusted
    path = tmp_path / 'p.mcap'
    make_points_mcap(path, 3000, 'none', chunk_size=1 << 24, shuffle=False)
    data = bytearray(path.read_bytes())
    payload = data.index(b'\x00\x00\x00\x00\x00\x00\xe0?', 2000)  # z = 0.5 of some message
    data[payload : payload + 8] = bytes(8)
    path.write_bytes(bytes(data))
    [report] = reindex(path).files
    assert report.action == 'refused'
    assert report.reason == ('3000 messages damaged at byte 39')
