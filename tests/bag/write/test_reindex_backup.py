"""``zros bag reindex`` never loses the original: it keeps it as ``NAME.orig.EXT`` (unless
``--no-backup``) and refuses to replace a file holding data with one holding no message."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from tests.bag.makebags import make_points_mcap, make_ros1_bag, make_sensor_bag
from tests.bag.read.test_damage import _ros1_chunks, zero_a_chunk
from zros.bag import Bag, BagError, reindex
from zros.cli.main import main


def test_a_rewritten_mcap_file_keeps_its_original_beside_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = make_sensor_bag(tmp_path / 'sensors', 6100)
    [file] = folder.glob('*.mcap')
    zero_a_chunk(file)
    damaged = file.read_bytes()
    assert main(['bag', 'reindex', str(folder)]) == 0
    backup = file.with_name(f'{file.stem}.orig.mcap')
    assert f'\n  the original is kept as {backup.name}\n' in capsys.readouterr().out
    assert backup.read_bytes() == damaged
    with Bag(file) as alone, Bag(folder) as bag:  # the backup is no storage file of the bag
        assert bag.message_count == alone.message_count and bag.skipped == []
    # a second rewrite never overwrites the first backup
    zero_a_chunk(file)
    again = file.read_bytes()
    [report] = reindex(folder).files
    assert report.backup == f'{file.stem}.orig-2.mcap'
    assert backup.read_bytes() == damaged and (folder / report.backup).read_bytes() == again


def test_no_backup_keeps_nothing(tmp_path: Path) -> None:
    file = make_points_mcap(tmp_path / 'p.mcap', 6100, chunk_size=1 << 16)
    zero_a_chunk(file)
    assert main(['bag', 'reindex', '--no-backup', str(file)]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ['p.mcap']
    [report] = reindex(file).files
    assert (report.action, report.backup) == ('complete', '')


def test_a_rewritten_ros1_bag_keeps_its_original(tmp_path: Path) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 1000)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 9 // 10])
    [report] = reindex(path).files
    assert (report.action, report.backup) == ('rewritten', 'r.orig.bag')
    assert (tmp_path / 'r.orig.bag').read_bytes() == data[: len(data) * 9 // 10]


def _damaged_with_failing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, call: str, error: OSError
) -> tuple[Path, bytes]:
    """A file with a zeroed chunk and its bytes; ``os.<call>`` raises ``error`` from now."""
    file = make_points_mcap(tmp_path / 'p.mcap', 6100, chunk_size=1 << 16)
    zero_a_chunk(file)

    def failing(*args: object) -> None:
        raise error

    monkeypatch.setattr(os, call, failing)
    return file, file.read_bytes()


def test_the_original_is_copied_where_it_cannot_be_linked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    error = OSError(18, 'Invalid cross-device link')
    file, damaged = _damaged_with_failing(tmp_path, monkeypatch, 'link', error)
    assert reindex(file).files[0].backup == 'p.orig.mcap'
    assert (tmp_path / 'p.orig.mcap').read_bytes() == damaged


def test_a_failed_rename_keeps_the_original_and_no_backup(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    error = OSError(30, 'Read-only file system')
    file, damaged = _damaged_with_failing(tmp_path, monkeypatch, 'replace', error)
    with pytest.raises(BagError, match=r'Read-only file system.*the original is unchanged'):
        reindex(file)
    assert file.read_bytes() == damaged
    assert [p.name for p in tmp_path.iterdir()] == ['p.mcap']


def _zero_the_only_chunk(file: Path) -> None:
    """Zero the start of the compressed data of a one-chunk zstd file: nothing of it reads."""
    data = bytearray(file.read_bytes())
    start = _only_chunk(file) + 1 + 8 * 4 + 4 + 4 + len('zstd') + 8
    data[start : start + 64] = bytes(64)
    file.write_bytes(bytes(data))


def test_reindex_refuses_to_keep_no_message_of_a_file_holding_some(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = make_points_mcap(tmp_path / 'p.mcap', 500, chunk_size=1 << 20)
    _zero_the_only_chunk(file)
    damaged = file.read_bytes()
    assert main(['bag', 'reindex', str(file)]) == 1
    assert capsys.readouterr().out == (
        'p.mcap: refused, left as it is: no message of it reads, so a rewrite would hold none '
        f'(500 messages damaged at byte {_only_chunk(file)})\n'
    )
    assert file.read_bytes() == damaged
    assert [p.name for p in tmp_path.iterdir()] == ['p.mcap']


def _only_chunk(file: Path) -> int:
    from mcap.reader import make_reader

    with file.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    [chunk] = summary.chunk_indexes
    return chunk.chunk_start_offset


def test_reindex_refuses_a_ros1_bag_of_which_nothing_reads(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 1000, 'lz4')
    first = _ros1_chunks(path)[0][0]
    path.write_bytes(cut := path.read_bytes()[: first + 40])  # inside its first chunk's header
    assert main(['bag', 'reindex', str(path)]) == 1
    out = capsys.readouterr().out
    assert out.startswith('r.bag: refused, left as it is: no message of it reads')
    assert path.read_bytes() == cut
    assert [p.name for p in tmp_path.iterdir()] == ['r.bag']


def test_a_bag_folder_with_a_refused_file_lists_the_others(
    testdata: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / 'wbag'
    shutil.copytree(testdata / 'ros2' / 'wbag_split_mcap', folder)
    last = folder / 'wbag_4.mcap'
    last.write_bytes(last.read_bytes()[:3000])
    assert main(['bag', 'reindex', str(folder)]) == 1
    out = capsys.readouterr().out
    assert 'wbag_4.mcap: refused' in out and 'in 4 files' in out
    assert 'wbag_4.mcap' not in (folder / 'metadata.yaml').read_text()
