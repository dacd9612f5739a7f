"""Damage costs only what is damaged: a damaged chunk or row is skipped with one warning and
counted in ``Bag.skipped``, everything else is read; ``strict=True`` raises instead."""

from __future__ import annotations

import logging
import os
import random
import shutil
from pathlib import Path

import pytest

from tests.bag.makebags import make_db3, make_points_mcap, make_sensor_bag
from tests.bag.reference import raw_messages
from zros.bag import Bag, BagError, bag_read
from zros.bag.read.damage import Skipped
from zros.cdr import encode, new_message

Messages = list[tuple[str, int, bytes]]


def _chunk_messages(path: Path, offset: int) -> Messages:
    """(topic, log time, data) of the messages of the MCAP chunk at ``offset``."""
    from mcap.records import Channel, Chunk, Message
    from mcap.stream_reader import StreamReader, breakup_chunk

    topics = {}
    with path.open('rb') as stream:
        for record in StreamReader(stream).records:
            if isinstance(record, Channel):
                topics[record.id] = record.topic
        stream.seek(offset)
        chunk = next(StreamReader(stream, skip_magic=True, emit_chunks=True).records)
    assert isinstance(chunk, Chunk)
    return [
        (topics[r.channel_id], r.log_time, r.data)
        for r in breakup_chunk(chunk)
        if isinstance(r, Message)
    ]


def zero_a_chunk(path: Path, which: int = -1) -> tuple[int, Messages]:
    """Zero 4 KB (at most half the chunk) in the middle of an MCAP file's chunk (default the
    middle one): its offset and the messages it held."""
    from mcap.reader import make_reader

    with path.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda index: index.chunk_start_offset)
    chunk = chunks[len(chunks) // 2 if which < 0 else which]
    lost = _chunk_messages(path, chunk.chunk_start_offset)
    size = min(4096, chunk.chunk_length // 2)
    middle = chunk.chunk_start_offset + chunk.chunk_length // 2 - size // 2
    data = bytearray(path.read_bytes())
    data[middle : middle + size] = bytes(size)
    path.write_bytes(bytes(data))
    return chunk.chunk_start_offset, lost


def _read(bag: Bag) -> Messages:
    return sorted(
        (t, s, bytes(raw.data))
        for raw in bag.raw_messages()
        for t, s in [(raw.connection.topic, raw.timestamp)]
    )


def _damage_warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if 'skipped the damaged data' in r.getMessage()]


def _check_mcap(
    bag_path: Path,
    file: Path,
    *,
    offset: int,
    whole: Messages,
    lost: Messages,
    caplog: pytest.LogCaptureFixture,
) -> None:
    expected = sorted(set(whole) - set(lost))
    assert len(expected) == len(whole) - len(lost) and lost
    per_topic = {}
    for topic, _, _ in lost:
        per_topic[topic] = per_topic.get(topic, 0) + 1
    with caplog.at_level(logging.WARNING, 'zros.bag'), Bag(bag_path) as bag:
        assert sum(1 for _ in bag.messages()) == len(expected)
        assert _read(bag) == expected
        for topic in per_topic:
            count = len(bag.columns(topic)['time'])
            assert count == sum(1 for t, _, _ in expected if t == topic)
        skipped = bag.skipped
    assert {(s.file, s.offset, s.row, s.topic, s.lost) for s in skipped} == {
        (file, offset, None, topic, count) for topic, count in per_topic.items()
    }
    # one warning for the chunk, however often it is read, naming file, offset, topics, counts
    [warning] = _damage_warnings(caplog)
    assert str(file) in warning and f'byte {offset}' in warning
    for topic, count in per_topic.items():
        assert f'{count} messages of {topic}' in warning or f'{count} message of {topic}' in warning
    assert len(bag_read(bag_path)) == len(expected)
    with pytest.raises(BagError, match=f'byte {offset}') as info, Bag(bag_path, strict=True) as bag:
        list(bag.messages())
    assert str(file) in str(info.value)
    with pytest.raises(BagError, match=f'byte {offset}'):
        bag_read(bag_path, strict=True)


def test_zeroed_chunk_of_a_bag_written_by_rosbags(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # uncompressed 1 MB chunks without CRC: the message index no longer matches the chunk
    folder = make_sensor_bag(tmp_path / 'sensors', 6100)
    [file] = folder.glob('*.mcap')
    whole = sorted((t, s, d) for t, _, s, d in raw_messages(file))
    offset, lost = zero_a_chunk(file)
    _check_mcap(folder, file, offset=offset, whole=whole, lost=lost, caplog=caplog)


def test_zeroed_zstd_chunk(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    file = make_points_mcap(tmp_path / 'points.mcap', 6100, chunk_size=1 << 16, shuffle=False)
    whole = sorted((t, s, d) for t, _, s, d in raw_messages(file))
    offset, lost = zero_a_chunk(file)
    _check_mcap(file, file, offset=offset, whole=whole, lost=lost, caplog=caplog)


def test_zeroed_chunk_of_a_real_split_bag(
    testdata: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / 'wbag'
    shutil.copytree(testdata / 'ros2' / 'wbag_split_mcap', folder)
    whole = sorted(
        (t, s, d) for i in range(5) for t, _, s, d in raw_messages(folder / f'wbag_{i}.mcap')
    )
    file = folder / 'wbag_2.mcap'
    offset, lost = zero_a_chunk(file)
    _check_mcap(folder, file, offset=offset, whole=whole, lost=lost, caplog=caplog)


def _garbage_db3(path: Path) -> tuple[Path, Messages, list[int]]:
    """/a (String) and /b (Point), 100 each; rows of 6 /b messages hold random bytes. The
    good messages and the garbage rows' ids."""
    rng = random.Random(7)
    rows: list[tuple[int, int, bytes]] = []
    good: Messages = []
    bad_rows = []
    for index in range(100):
        text = encode(new_message('std_msgs/msg/String', data=f'a{index}'))
        rows.append((0, 1000 + index * 10, text))
        good.append(('/a', 1000 + index * 10, text))
        point = encode(new_message('geometry_msgs/msg/Point', x=index, y=0, z=0))
        if index % 17 == 5:
            point = rng.randbytes(len(point) + 5)
            bad_rows.append(len(rows) + 1)
        else:
            good.append(('/b', 1005 + index * 10, point))
        rows.append((1, 1005 + index * 10, point))
    make_db3(path, [('/a', 'std_msgs/msg/String'), ('/b', 'geometry_msgs/msg/Point')], rows)
    return path, sorted(good), bad_rows


def test_garbage_rows_of_a_db3_are_skipped_on_every_path(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path, good, bad_rows = _garbage_db3(tmp_path / 'garbage.db3')
    assert len(bad_rows) == 6
    with caplog.at_level(logging.WARNING, 'zros.bag'), Bag(path) as bag:
        got = [(t, s, encode(m)) for t, s, m in bag.messages()]
        assert sorted(got) == good
        assert sum(1 for _ in bag) == len(good)
        columns = bag.columns('/b', ['x'])
        assert columns['x'].tolist() == [float(i) for i in range(100) if i % 17 != 5]
        assert len(bag.columns('/a')['time']) == 100
        assert len(bag.to_numpy('/b')) == 94
        skipped = bag.skipped
    assert [(s.file, s.offset, s.row, s.topic, s.lost) for s in skipped] == [
        (path, None, row, '/b', 1) for row in bad_rows
    ]
    warnings = _damage_warnings(caplog)
    assert len(warnings) == 6 and all(
        f'row {r}' in w for r, w in zip(bad_rows, warnings, strict=True)
    )
    assert len(bag_read(path)) == len(good)
    assert len(bag_read(path, '/b')) == 94
    with pytest.raises(BagError, match=f'row {bad_rows[0]}'):
        bag_read(path, strict=True)
    with pytest.raises(BagError, match=f'row {bad_rows[0]}'), Bag(path, strict=True) as bag:
        bag.columns('/b')


def test_garbage_rows_reach_pandas(tmp_path: Path) -> None:
    pytest.importorskip('pandas')
    path, _, _ = _garbage_db3(tmp_path / 'garbage.db3')
    with Bag(path) as bag:
        assert len(bag.to_dataframe('/b')) == 94


def test_the_first_message_damaged_does_not_settle_the_columns(tmp_path: Path) -> None:
    point = encode(new_message('geometry_msgs/msg/Point', x=2.0))
    path = make_db3(
        tmp_path / 'first.db3',
        [('/b', 'geometry_msgs/msg/Point')],
        [(0, 1, os.urandom(40)), (0, 2, point), (0, 3, os.urandom(3))],
    )
    with Bag(path) as bag:
        assert bag.columns('/b')['x'].tolist() == [2.0]
        assert [s.row for s in bag.skipped] == [1, 3]


@pytest.mark.parametrize('name', ['not a/type!', 'a/b/c/d', 'pkg/msg/bad-name', 'x', ''])
def test_a_bad_type_name_fails_only_its_topic(tmp_path: Path, name: str) -> None:
    text = encode(new_message('std_msgs/msg/String', data='hi'))
    path = make_db3(
        tmp_path / 'bad.db3',
        [('/a', 'std_msgs/msg/String'), ('/b', name)],
        [(0, 1, text), (1, 2, b'\x00\x01\x00\x00' + bytes(8)), (0, 3, text)],
        {'std_msgs/msg/String': 'string data\n', name: 'float64 x\n'},
    )
    with Bag(path) as bag:
        assert [m.data for _, _, m in bag.messages('/a')] == ['hi', 'hi']
        assert len(list(bag.messages())) == 3  # /b's message comes back undecoded
        assert len(bag.columns('/a')['time']) == 2
        with pytest.raises(BagError) as info:
            bag.columns('/b')
        recorded = bag.topics['/b'].type_name  # as stored (a two-part name gets its /msg/)
    text_of = str(info.value)
    assert str(path) in text_of and 'topic /b' in text_of and f'type {recorded},' in text_of
    assert len(bag_read(path)) == 3


def test_a_skipped_record_reads_as_text(tmp_path: Path) -> None:
    skipped = Skipped(tmp_path / 'x.mcap', 12, None, '/t', 3, 'zstd error')
    assert (
        str(skipped)
        == f'{tmp_path / "x.mcap"}: skipped the damaged data at byte 12 (zstd error): lost 3 messages of /t'
    )
    assert Skipped(tmp_path, None, 4, '/t', 1, 'r').where == 'row 4'
    assert 'an unknown number of messages' in str(Skipped(tmp_path, None, None, '/t', -1, 'r'))
