"""``zros bag reindex``: a bag a killed recorder left reads again in rosbags, the mcap library
and zros, up to its last whole message; the original is never lost on the way."""

from __future__ import annotations

import hashlib
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tests.bag.reference import raw_messages
from tests.bag.write.test_record import bag_yaml
from tests.bag.write.test_record_cli import complete_chunks, texts, zros_cli  # noqa: F401
from tests.cli.conftest import Cli
from zros.bag import Bag, BagError, BagTopic, BagWriter, reindex
from zros.bag.read.rosbag2 import storage_files
from zros.bag.write.reindexer import FileReport, ReindexReport
from zros.cdr import default_registry, encode
from zros.testing import wait_for
from zros.version import counted

Node = Callable[..., Any]
STRING = 'std_msgs/msg/String'


# --- what each reader sees ------------------------------------------------------------------


def rosbags_reader(folder: Path) -> list[tuple[str, bytes]]:
    from rosbags.rosbag2 import Reader

    with Reader(folder) as reader:
        found = [(c.topic, bytes(data)) for c, _, data in reader.messages()]
        assert reader.message_count == len(found)
    return found


def any_reader(folder: Path) -> list[tuple[str, str]]:
    from rosbags.highlevel import AnyReader

    with AnyReader([folder]) as reader:
        found: list[tuple[str, str]] = []
        for connection, _, data in reader.messages():
            message: Any = reader.deserialize(data, connection.msgtype)
            found.append((connection.topic, message.data))
        return found


def mcap_reader(file: Path) -> list[tuple[str, bytes]]:
    """The mcap library's default reader: its summary and its messages must agree."""
    from mcap.reader import make_reader

    with file.open('rb') as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        found = [(c.topic, m.data) for _, c, m in reader.iter_messages(log_time_order=False)]
        assert summary.statistics.message_count == len(found)
    return found


def zros_info_count(cli: Cli, folder: Path) -> int:
    result = cli.run('bag', 'info', str(folder))
    assert result.returncode == 0, result.stderr
    line = next(line for line in result.stdout.splitlines() if line.startswith('Messages:'))
    return int(line.split()[1])


# --- a real recorder, killed ------------------------------------------------------------------


def test_a_killed_recording_reads_everywhere_after_reindex(
    zros_cli: Cli,  # noqa: F811
    zros_node: Node,
    tmp_path: Path,
) -> None:
    folder = tmp_path / 'killed'
    # files of ~64 KiB: the recording splits, so complete files and the unfinished last one mix
    running = zros_cli.start('bag', 'record', '-o', str(folder), '-b', '65536', '/burst')
    talker = zros_node('talker')
    publisher = talker.create_publisher(STRING, '/burst', 'keep_all')
    running.wait_line(lambda line: line == 'Subscribed to topic /burst [std_msgs/msg/String]')
    assert publisher.wait_for_subscribers()
    # written at the start, kept current: a killed bag names its files and topics
    assert (folder / 'metadata.yaml').is_file()
    # hex digests: zstd cannot shrink them much, so the files do split
    sent = [f'{n:05d} ' + hashlib.sha512(str(n).encode()).hexdigest() for n in range(3000)]

    def on_disk() -> list[tuple[str, bytes]]:
        return [m for file in storage_files(folder) for m in complete_chunks(file)]

    for text in sent[:1500]:
        publisher.write(publisher.msg_type(data=text))
    assert wait_for(lambda: len(on_disk()) == 1500, 30)
    for text in sent[1500:]:
        publisher.write(publisher.msg_type(data=text))
    running.process.kill()  # SIGKILL: no chance to finish anything
    running.process.wait(10)

    files = storage_files(folder)
    assert len(files) > 2
    complete = [m for file in files for m in complete_chunks(file)]
    assert texts(complete) == sent[: len(complete)]  # in order, nothing missing before the cut
    assert len(complete) >= 1500
    # kept current at each split: it names every file (but one just opened, at worst)
    listed = [f['path'] for f in bag_yaml(folder)['files']]
    assert listed == [f.name for f in files][: len(listed)] and len(listed) >= len(files) - 1
    from mcap.exceptions import McapError

    with pytest.raises(McapError):  # what reindex repairs: the mcap reader refuses the file
        mcap_reader(files[-1])

    result = zros_cli.run('bag', 'reindex', str(folder))
    assert result.returncode == 0, result.stderr
    # the last file is finished from its complete records; one killed before even its header
    # reached the disk (a split just then) holds nothing and is left out
    skipped = f'{files[-1].name}: skipped' in result.stdout
    assert skipped or f'{files[-1].name}: rewritten, ' in result.stdout
    used = files[:-1] if skipped else files
    # the complete chunks, and the whole messages of a last chunk the kill cut short, if any
    recovered = [m for file in used for m in mcap_reader(file)]
    assert recovered[: len(complete)] == complete and texts(recovered) == sent[: len(recovered)]
    assert f'{len(recovered)} messages on 1 topic in {counted(len(used), "file")}' in result.stdout

    assert rosbags_reader(folder) == recovered
    assert any_reader(folder) == [(topic, text) for topic, text in zip(
        ['/burst'] * len(recovered), texts(recovered), strict=True
    )]  # fmt: skip
    assert zros_info_count(zros_cli, folder) == len(recovered)
    yaml = bag_yaml(folder)
    assert yaml['message_count'] == len(recovered)
    assert [f['path'] for f in yaml['files']] == [f.name for f in used]
    assert yaml['ros_distro'] == default_registry().distro  # kept from the recorder's file
    # a second run finds every file finished and changes nothing
    again = reindex(folder)
    assert [f.action for f in again.files] == ['complete'] * len(used) + ['skipped'] * skipped
    assert again.message_count == len(recovered)


# --- the Python face and its edges ------------------------------------------------------------


def _killed_bag(folder: Path, count: int, flushed: int) -> list[bytes]:
    """A bag as a killed writer leaves it: ``flushed`` messages in closed chunks, the rest in
    memory (lost), the file never finished. Returns the messages written."""
    registry = default_registry()
    cls = registry.get_class(STRING)
    writer = BagWriter(folder, chunk_size=2048)
    topic = writer.add_topic(BagTopic.from_registry(registry, '/chatter', STRING))
    data = [encode(cls(data=f'm{n}')) for n in range(count)]
    for n, payload in enumerate(data):
        writer.write(topic, 1_000_000_000 + n, payload)
        if n + 1 == flushed:
            writer.flush()
            shutil.copytree(folder, folder.with_name('copy'))
    writer.close()
    shutil.rmtree(folder)
    folder.with_name('copy').rename(folder)
    return data


def test_reindex_keeps_every_complete_chunk_of_a_file(tmp_path: Path) -> None:
    folder = tmp_path / 'bag'
    data = _killed_bag(folder, 600, 400)
    file = folder / 'bag_0.mcap'
    kept = [d for _, d in complete_chunks(file)]
    assert len(kept) == 400 and kept == data[:400]
    report = reindex(folder)
    assert [f.action for f in report.files] == ['rewritten']
    assert report.message_count == 400
    assert str(report).startswith('bag_0.mcap: rewritten, 400 messages up to its last')
    assert [d for _, d in mcap_reader(file)] == kept
    assert [d for _, d in rosbags_reader(folder)] == kept
    with Bag(folder) as bag:
        assert [m.data for _, _, m in bag.messages()] == [f'm{n}' for n in range(400)]
    assert not list(folder.glob('.*'))  # no temporary file left


def test_reindex_a_bare_mcap_file(tmp_path: Path) -> None:
    folder = tmp_path / 'bag'
    _killed_bag(folder, 300, 200)
    file = folder / 'bag_0.mcap'
    report = reindex(file)
    assert report.metadata is None and report.message_count == 200
    assert len(mcap_reader(file)) == 200


def test_a_failed_rewrite_leaves_the_original(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcap.writer import Writer

    folder = tmp_path / 'bag'
    _killed_bag(folder, 300, 200)
    file = folder / 'bag_0.mcap'
    before = file.read_bytes()
    (folder / '.bag_0.mcap.reindex').write_bytes(b'left by an interrupted reindex')

    def disk_full(self: Any) -> None:
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(Writer, 'finish', disk_full)
    with pytest.raises(BagError, match=r'No space left on device.*the original is unchanged'):
        reindex(folder)
    assert file.read_bytes() == before
    assert not list(folder.glob('.*'))
    monkeypatch.undo()
    assert reindex(folder).message_count == 200


def test_split_bag_with_nothing_complete_in_its_last_file(testdata: Path, tmp_path: Path) -> None:
    folder = tmp_path / 'wbag'
    shutil.copytree(testdata / 'ros2' / 'wbag_split_mcap', folder)
    (folder / 'metadata.yaml').unlink()
    last = folder / 'wbag_4.mcap'
    last.write_bytes(cut := last.read_bytes()[:3000])  # its one chunk cut in the middle
    whole = [m for i in range(4) for m in raw_messages(folder / f'wbag_{i}.mcap')]
    report = reindex(folder)
    # no whole message in it: left as it is (not emptied), not listed, and said so
    assert [f.action for f in report.files] == ['complete'] * 4 + ['refused']
    assert report.refused and last.read_bytes() == cut
    assert str(report.files[-1]).startswith(
        'wbag_4.mcap: refused, left as it is: no message of it reads, so a rewrite would hold '
        'none (2'
    )
    assert str(report).endswith(f'{report.message_count} messages on 8 topics in 4 files')
    assert len(rosbags_reader(folder)) == len(whole) == 6074 - 1108
    with Bag(folder) as bag:
        assert bag.message_count == len(whole)


def test_reindex_refusals(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='no such file or folder'):
        reindex(tmp_path / 'absent')
    with pytest.raises(BagError, match=r'no \.mcap file'):
        reindex(tmp_path)
    (tmp_path / 'x.db3').write_bytes(b'')
    with pytest.raises(BagError, match=r'\.db3'):
        reindex(tmp_path)
    with pytest.raises(BagError, match='MCAP and ROS 1 bags'):
        reindex(tmp_path / 'x.db3')
    junk = tmp_path / 'junk'
    junk.mkdir()
    (junk / 'junk_0.mcap').write_bytes(b'not an mcap file')
    report = reindex(junk)
    assert [(f.action, f.reason) for f in report.files] == [('skipped', 'no MCAP magic')]


def test_the_summary_counts_one_as_one(tmp_path: Path) -> None:
    files = [FileReport('bag_0.mcap', 'complete', 1)]
    report = ReindexReport(tmp_path, files, tmp_path / 'metadata.yaml', 1)
    assert str(report).splitlines()[-1] == (
        f'Wrote {tmp_path / "metadata.yaml"}: 1 message on 1 topic in 1 file'
    )


def test_a_file_report_counts_in_words() -> None:
    from zros.bag.write.reindexer import FileReport

    assert str(FileReport('a.mcap', 'complete', 1)) == 'a.mcap: complete, 1 message'
    damaged = FileReport('b.mcap', 'rewritten', 2, lost_messages=1, damaged=(70,))
    assert str(damaged) == (
        'b.mcap: rewritten, 2 messages; could not keep 1 message (damaged or cut short at byte 70)'
    )
