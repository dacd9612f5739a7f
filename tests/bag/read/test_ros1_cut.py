"""A ROS 1 bag whose end cuts its last chunk short (an interrupted recording shorter than one
chunk, 768 KB by default) keeps the whole messages of the chunk's part present, uncompressed,
bz2 or lz4, and ``zros bag reindex`` keeps them."""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import pytest

from tests.bag.makebags import make_ros1_bag
from tests.bag.read.test_damage import _ros1_chunks
from zros.bag import Bag, reindex
from zros.bag.read.lz4_part import decompress_part

Raw = list[tuple[str, int, bytes]]


def _raw(path: Path) -> tuple[Raw, list[tuple[str, str, int, str]]]:
    with Bag(path) as bag:
        got = [(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()]
        assert bag.message_count == len(got)
        return got, [(s.where, s.topic, s.lost, s.reason) for s in bag.skipped]


def _cut(source: Path, target: Path, cut: int) -> int:
    target.write_bytes(source.read_bytes()[:cut])
    return cut


def _check_cut(
    intact: Path,
    cut_file: Path,
    fraction: float,
    caplog: pytest.LogCaptureFixture,
    whole_file: bool,
) -> int:
    """Cut ``intact`` into ``cut_file``: its messages are the intact file's first ones, the
    skipped entry and warnings say where the file ends and what was read; reindex keeps
    them. The number read."""
    whole, _ = _raw(intact)
    [(chunk, chunk_end, _)] = _ros1_chunks(intact)
    size = intact.stat().st_size
    # the file at 60 %, or its chunk at 60 % (a compressed chunk is a small part of the file)
    at = int(size * fraction) if whole_file else chunk + int((chunk_end - chunk) * fraction)
    end = _cut(intact, cut_file, at)
    with caplog.at_level(logging.WARNING, logger='zros.bag'):
        got, skipped = _raw(cut_file)
    assert 0 < len(got) < len(whole)
    assert got == whole[: len(got)]
    [(where, topic, lost, reason)] = skipped
    assert (where, topic, lost) == (f'byte {chunk}', '', -1)
    assert reason.startswith(f'the file ends at byte {end}, inside the chunk at byte {chunk} (')
    assert reason.endswith(f': its first {len(got)} messages were read, the rest of it is lost')
    assert "('" not in caplog.text  # no tuple repr from rosbags
    [report] = reindex(cut_file).files
    assert (report.action, report.message_count) == ('rewritten', len(got))
    assert _raw(cut_file) == (got, [])
    return len(got)


@pytest.mark.parametrize(('compression', 'count'), [(None, 2000), ('lz4', 2000), ('bz2', 12000)])
def test_a_ros1_bag_cut_inside_its_one_chunk_reads_what_is_present(
    tmp_path: Path, compression: str | None, count: int, caplog: pytest.LogCaptureFixture
) -> None:
    # bz2 decompresses in blocks of 900 KB: the chunk holds several
    intact = make_ros1_bag(tmp_path / 'r.bag', count, compression, chunk_threshold=1 << 24)
    _check_cut(intact, tmp_path / 'cut.bag', 0.6, caplog, whole_file=False)


@pytest.mark.parametrize(('name', 'read'), [('tf_franka.bag', 535), ('tf_example.bag', 387)])
def test_real_ros1_bags_cut_at_60_percent(
    testdata: Path, tmp_path: Path, name: str, read: int, caplog: pytest.LogCaptureFixture
) -> None:
    intact = tmp_path / name
    shutil.copy(testdata / 'ros1' / name, intact)
    assert _check_cut(intact, tmp_path / 'cut.bag', 0.6, caplog, whole_file=True) == read


def test_damage_in_the_part_present_stops_the_read_there(tmp_path: Path) -> None:
    intact = make_ros1_bag(tmp_path / 'r.bag', 2000, chunk_threshold=1 << 24)
    whole, _ = _raw(intact)
    data = bytearray(intact.read_bytes()[: intact.stat().st_size * 6 // 10])
    middle = len(data) // 3
    data[middle : middle + 64] = bytes(64)
    cut = tmp_path / 'cut.bag'
    cut.write_bytes(bytes(data))
    with Bag(cut) as bag:
        got = [(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()]
        reasons = [s.reason for s in bag.skipped]
    assert 0 < len(got) < len(whole) // 3 and got == whole[: len(got)]
    assert any('the rest of it is lost (a record in the chunk: ' in r for r in reasons)


def test_an_lz4_frame_cut_anywhere_gives_a_prefix_of_its_output() -> None:
    import lz4.frame

    text = b''.join(b'frame %d base_link ' % (n % 97) for n in range(40000))
    for linked in (True, False):
        frame = lz4.frame.compress(
            text, block_size=lz4.frame.BLOCKSIZE_MAX64KB, block_linked=linked, block_checksum=True
        )
        assert decompress_part(frame, len(text)) == text
        for cut in range(7, len(frame), len(frame) // 13):
            assert text.startswith(decompress_part(frame[:cut], len(text)))
        assert len(decompress_part(frame[: len(frame) // 2], len(text))) > len(text) // 3


def test_an_lz4_frame_that_does_not_parse() -> None:
    import lz4.frame

    text = b'abcd' * 1000
    frame = lz4.frame.compress(text, block_size=lz4.frame.BLOCKSIZE_MAX64KB)
    with pytest.raises(ValueError, match='not an LZ4 frame'):
        decompress_part(b'\x00' * 20, 100)
    with pytest.raises(ValueError, match='more than its header declares'):
        decompress_part(frame, 100)
    head = lz4.frame.compress(b'', store_size=False)[:7]
    broken = head + (3).to_bytes(4, 'little') + bytes(3)  # a match of offset 0
    with pytest.raises(ValueError, match='does not parse'):
        decompress_part(broken, len(text))


@pytest.mark.parametrize('compression', ['bz2', 'lz4'])
def test_a_cut_chunk_decompressing_to_more_than_declared_is_damage(
    tmp_path: Path, compression: str
) -> None:
    from zros.bag.read.rosbag1_scan import ScannedBag1

    intact = make_ros1_bag(tmp_path / 'r.bag', 12000, compression, chunk_threshold=1 << 24)
    [(chunk, chunk_end, _)] = _ros1_chunks(intact)
    data = bytearray(intact.read_bytes()[: chunk + (chunk_end - chunk) * 9 // 10])
    size = data.index(b'size=', chunk) + len(b'size=')
    data[size : size + 4] = (10).to_bytes(4, 'little')  # the chunk declares 10 bytes
    cut = tmp_path / 'cut.bag'
    cut.write_bytes(bytes(data))
    scan = ScannedBag1(cut)
    scan.open()
    [(at, lost, reason)] = scan.losses
    assert (at, lost, scan.connections) == (chunk, {-1: -1}, [])
    assert reason.endswith(
        'no whole message in the part present, that chunk is lost '
        '(it decompresses to more than its header declares)'
    )
