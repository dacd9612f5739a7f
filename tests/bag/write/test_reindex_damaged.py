"""``zros bag reindex`` of damaged bags: MCAP files with a damaged chunk (summary intact or
gone) and ROS 1 bags (cut short, damaged chunks) are rebuilt from what reads, and the report
says how many messages could not be kept."""

from __future__ import annotations

import shutil
import struct
from pathlib import Path

import pytest

from tests.bag.makebags import make_points_mcap, make_ros1_bag, make_sensor_bag
from tests.bag.read.test_damage import _ros1_chunks, zero_a_chunk
from tests.bag.reference import raw_messages
from zros.bag import Bag, reindex
from zros.cli.main import main


def _mcap_messages(file: Path) -> list[tuple[str, int, bytes]]:
    """What the mcap library's own reader reads (summary and messages must agree)."""
    from mcap.reader import make_reader

    with file.open('rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        found = [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages()]
        assert summary.statistics.message_count == len(found)
    return sorted(found)


@pytest.mark.parametrize('writer', ['mcap', 'rosbags'])
def test_reindex_repairs_a_zeroed_chunk_of_a_finished_file(
    tmp_path: Path, writer: str, capsys: pytest.CaptureFixture[str]
) -> None:
    if writer == 'mcap':
        file = path = make_points_mcap(tmp_path / 'p.mcap', 6100, chunk_size=1 << 16)
    else:  # uncompressed chunks without CRC
        path = make_sensor_bag(tmp_path / 'sensors', 6100)
        [file] = path.glob('*.mcap')
    whole = sorted((t, s, d) for t, _, s, d in raw_messages(file))
    offset, lost = zero_a_chunk(file)
    expected = sorted(set(whole) - set(lost))
    assert main(['bag', 'reindex', str(path)]) == 0
    out = capsys.readouterr().out
    assert (
        f'{file.name}: rewritten, {len(expected)} messages; could not keep {len(lost)} '
        f'messages (damaged or cut short at byte {offset})'
    ) in out
    assert _mcap_messages(file) == expected
    with Bag(path) as bag:
        assert sum(1 for _ in bag) == bag.message_count == len(expected)
        assert bag.skipped == []
    # now whole: left as it is
    [report] = reindex(path).files
    assert (report.action, report.message_count) == ('complete', len(expected))


def test_a_damaged_chunk_of_a_file_without_summary_is_skipped_and_the_scan_goes_on(
    tmp_path: Path,
) -> None:
    file = make_points_mcap(tmp_path / 'p.mcap', 6100, chunk_size=1 << 16, shuffle=False)
    whole = sorted((t, s, d) for t, _, s, d in raw_messages(file))
    offset, lost = zero_a_chunk(file, 1)
    from mcap.reader import make_reader

    with file.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    data_end = max(i.chunk_start_offset + i.chunk_length for i in summary.chunk_indexes)
    file.write_bytes(file.read_bytes()[:data_end])  # the summary and footer are gone
    expected = sorted(set(whole) - set(lost))
    with Bag(file) as bag:
        got = sorted((r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages())
        assert bag.message_count == len(expected)
        [skipped] = bag.skipped
    assert got == expected
    assert (skipped.offset, skipped.topic, skipped.lost) == (offset, '/point', len(lost))
    [report] = reindex(file).files
    assert (report.action, report.message_count, report.lost_messages) == (
        'rewritten',
        len(expected),
        len(lost),
    )
    assert _mcap_messages(file) == expected


def test_reindex_of_a_real_split_bag_with_a_zeroed_chunk(testdata: Path, tmp_path: Path) -> None:
    folder = tmp_path / 'wbag'
    shutil.copytree(testdata / 'ros2' / 'wbag_split_mcap', folder)
    file = folder / 'wbag_2.mcap'
    kept = len(raw_messages(folder)) - len(zero_a_chunk(file)[1])
    damaged = file.read_bytes()
    report = reindex(folder)
    # its one chunk is its every message: left as it is, not emptied
    assert [f.action for f in report.files] == ['complete'] * 2 + ['refused'] + ['complete'] * 2
    assert report.message_count == kept and file.read_bytes() == damaged
    with Bag(folder) as bag:
        assert sum(1 for _ in bag) == bag.message_count == kept


@pytest.mark.parametrize('compression', [None, 'bz2'])
def test_reindex_rebuilds_a_ros1_bag_cut_short(
    tmp_path: Path, compression: str | None, capsys: pytest.CaptureFixture[str]
) -> None:
    from rosbags.rosbag1 import Reader, ReaderError

    path = make_ros1_bag(tmp_path / 'r.bag', 1000, compression)
    chunks = _ros1_chunks(path)
    data = path.read_bytes()
    cut = len(data) * 9 // 10
    path.write_bytes(data[:cut])
    expected = sorted(m for _, end, found in chunks if end <= cut for m in found)
    present = [m for at, end, found in chunks if at < cut < end for m in found]
    with Bag(path) as bag:  # and the whole messages at the start of the chunk cut short
        expected += sorted(present, key=lambda m: m[1])[: bag.message_count - len(expected)]
    expected.sort()
    with pytest.raises(ReaderError, match='index'), Reader(path):  # rosbags cannot open it
        pass
    assert main(['bag', 'reindex', str(path)]) == 0
    out = capsys.readouterr().out
    assert f'r.bag: rewritten, {len(expected)} messages; could not keep an unknown number' in out
    with Reader(path) as reader:  # rosbags reads it now
        got = sorted((c.topic, t) for c, t, _ in reader.messages())
    assert got == expected
    with Bag(path) as bag:
        assert bag.skipped == [] and sum(1 for _ in bag) == len(expected)
    assert [f.action for f in reindex(path).files] == ['complete']


def test_reindex_drops_a_ros1_chunk_that_does_not_decompress(tmp_path: Path) -> None:
    from rosbags.rosbag1 import Reader

    path = make_ros1_bag(tmp_path / 'r.bag', 1000, 'lz4')
    chunks = _ros1_chunks(path)
    offset, end, lost = chunks[3]
    data = bytearray(path.read_bytes())
    data[(offset + end) // 2 : (offset + end) // 2 + 16] = bytes(16)
    path.write_bytes(bytes(data))
    whole = sorted(m for _, _, found in chunks for m in found)
    [report] = reindex(path).files
    assert (report.action, report.lost_messages, report.damaged) == (
        'rewritten',
        len(lost),
        (offset,),
    )
    with Reader(path) as reader:
        got = sorted((c.topic, t) for c, t, _ in reader.messages())
    assert got == sorted(set(whole) - set(lost))


@pytest.mark.parametrize('cut', [False, True])
def test_a_ros1_message_that_does_not_convert_counts_the_same_in_reader_and_reindex(
    tmp_path: Path, cut: bool
) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 300)
    chunks = _ros1_chunks(path)
    data = bytearray(path.read_bytes())
    text = b'message 150 ' * 3
    at = data.index(struct.pack('<L', len(text)) + text)
    data[at : at + 4] = struct.pack('<L', 0x7FFFFFFF)  # its string's length: the record parses
    if cut:  # and the index at the end gone: the bag is scanned
        data = data[: chunks[-1][1]]
    path.write_bytes(bytes(data))
    (chunk,) = [offset for offset, end, _ in chunks if offset < at < end]
    with Bag(path) as bag:
        kept = sum(1 for _ in bag.raw_messages())
        skipped = [s for s in bag.skipped if s.lost > 0]
    assert kept == 599
    assert [(s.where, s.topic, s.lost) for s in skipped] == [(f'byte {chunk}', '/a', 1)]
    assert 'does not convert' in skipped[0].reason
    [report] = reindex(path).files
    assert (report.action, report.message_count) == ('rewritten', kept)
    assert chunk in report.damaged
    if not cut:
        assert report.lost_messages == 1
    with Bag(path) as bag:  # the rewritten bag reads whole
        assert bag.skipped == [] and sum(1 for _ in bag.raw_messages()) == kept


def test_reindex_refuses_what_is_no_ros1_bag(tmp_path: Path) -> None:
    from zros.bag import BagError

    path = tmp_path / 'x.bag'
    path.write_bytes(b'not a bag at all')
    with pytest.raises(BagError, match='cannot read it as a ROS 1 bag'):
        reindex(path)


def test_a_failed_ros1_rewrite_leaves_the_original(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rosbags.rosbag1 import Writer

    from zros.bag import BagError

    path = make_ros1_bag(tmp_path / 'r.bag', 300)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 9 // 10])
    before = path.read_bytes()

    def disk_full(*args: object) -> None:
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(Writer, 'write', disk_full)
    with pytest.raises(BagError, match='original is unchanged'):
        reindex(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ['r.bag']
