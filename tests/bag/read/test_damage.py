"""Damage costs only what is damaged: a damaged chunk or row is skipped with one warning and
counted in ``Bag.skipped``, everything else is read; ``strict=True`` raises instead."""

from __future__ import annotations

import logging
import os
import random
import shutil
from pathlib import Path

import pytest

from tests.bag.makebags import make_db3, make_points_mcap, make_ros1_bag, make_sensor_bag
from tests.bag.reference import raw_messages
from zros.bag import Bag, BagError, bag_read, reindex
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
    with Bag(bag_path) as bag:  # and the start of the chunk its message index confirms
        kept = sorted(set(_read(bag)) - set(expected))
    caplog.clear()
    assert sorted(lost[: len(kept)]) == kept
    expected, lost = sorted(expected + kept), lost[len(kept) :]
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


# --- ROS 1 ------------------------------------------------------------------------------------


def _ros1_chunks(path: Path) -> list[tuple[int, int, list[tuple[str, int]]]]:
    """(offset, end, [(topic, time)]) of each chunk of an intact ROS 1 bag, in file order."""
    from rosbags.rosbag1 import Reader

    with Reader(path) as reader:
        found: dict[int, list[tuple[str, int]]] = {pos: [] for pos in reader.chunks}
        for connection in reader.connections:
            for entry in reader.indexes[connection.id]:
                found[entry.chunk_pos].append((connection.topic, entry.time))
        return [
            (pos, chunk.datapos + chunk.datasize, sorted(found[pos]))
            for pos, chunk in sorted(reader.chunks.items())
        ]


def _ros1_read(path: Path) -> tuple[list[tuple[str, int]], list[Skipped]]:
    with Bag(path) as bag:
        got = sorted((raw.connection.topic, raw.timestamp) for raw in bag.raw_messages())
        assert sum(1 for _ in bag.messages()) == len(got)
        return got, bag.skipped


@pytest.mark.parametrize('compression', [None, 'lz4', 'bz2'])
def test_ros1_bag_cut_at_90_percent_reads_what_is_there(
    tmp_path: Path, compression: str | None
) -> None:
    original = make_ros1_bag(tmp_path / 'whole.bag', 1000, compression)
    chunks = _ros1_chunks(original)
    assert len(chunks) > 10
    data = original.read_bytes()
    cut = len(data) * 9 // 10
    path = tmp_path / 'cut.bag'
    path.write_bytes(data[:cut])
    expected = sorted(m for _, end, found in chunks if end <= cut for m in found)
    assert 0 < len(expected) < 2000
    # and the whole messages of the chunk the cut falls in, from its start
    present = [m for at, end, found in chunks if at < cut < end for m in found]
    got, skipped = _ros1_read(path)
    first = sorted(present, key=lambda m: m[1])[: len(got) - len(expected)]
    assert got == sorted(expected + first)
    # what lay past the cut is unknown: the index at the end is gone
    assert [(s.topic, s.lost) for s in skipped] == [('', -1)]
    assert skipped[0].offset is not None and skipped[0].offset <= cut
    with Bag(path) as bag:
        assert bag.message_count == len(got)
        assert len(bag.columns('/b')['x']) == sum(1 for t, _ in got if t == '/b')
    with pytest.raises(BagError, match=r'the file ends at byte|cut short'), Bag(path, strict=True):
        pass


@pytest.mark.parametrize('compression', ['lz4', 'bz2'])
def test_ros1_chunk_that_does_not_decompress_is_skipped(
    tmp_path: Path, compression: str, caplog: pytest.LogCaptureFixture
) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 1000, compression)
    chunks = _ros1_chunks(path)
    offset, end, lost = chunks[len(chunks) // 2]
    data = bytearray(path.read_bytes())
    middle = (offset + end) // 2
    data[middle : middle + 16] = bytes(16)  # inside the compressed data, the index intact
    path.write_bytes(bytes(data))
    whole = sorted(m for _, _, found in chunks for m in found)
    with caplog.at_level(logging.WARNING, 'zros.bag'):
        got, skipped = _ros1_read(path)
    assert got == sorted(set(whole) - set(lost))
    counts = {t: sum(1 for topic, _ in lost if topic == t) for t in ('/a', '/b')}
    assert sorted((s.offset, s.topic, s.lost) for s in skipped) == [
        (offset, topic, count) for topic, count in counts.items() if count
    ]
    [warning] = _damage_warnings(caplog)
    assert str(path) in warning and f'byte {offset}' in warning
    with pytest.raises(BagError, match=f'byte {offset}'), Bag(path, strict=True) as bag:
        list(bag.messages())


def test_ros1_record_with_a_flipped_byte_loses_one_message(tmp_path: Path) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 300)
    whole = sorted(m for _, _, found in _ros1_chunks(path) for m in found)
    data = bytearray(path.read_bytes())
    # the op field of a message record's header, in an uncompressed chunk
    at = data.index(b'op=\x02', len(data) // 3) + 3
    data[at] ^= 0x08
    path.write_bytes(bytes(data))
    got, skipped = _ros1_read(path)
    assert len(got) == len(whole) - 1 and set(got) <= set(whole)
    [lost] = skipped
    assert lost.lost == 1 and lost.topic in ('/a', '/b') and lost.offset is not None


@pytest.mark.parametrize('compression', [None, 'lz4', 'bz2'])
@pytest.mark.parametrize('seed', range(6))
def test_ros1_flipped_bytes_never_raise(tmp_path: Path, compression: str | None, seed: int) -> None:
    original = make_ros1_bag(tmp_path / 'whole.bag', 400, compression)
    whole = set(m for _, _, found in _ros1_chunks(original) for m in found)
    data = bytearray(original.read_bytes())
    rng = random.Random(seed)
    for _ in range(8):
        data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    path = tmp_path / 'flipped.bag'
    path.write_bytes(bytes(data))
    got, skipped = _ros1_read(path)  # never raises: damage is skipped
    # flipped bytes may change a time or a value, not invent messages from nowhere
    assert len(got) <= len(whole)
    assert len(set(got) & whole) >= len(whole) // 2
    known = sum(s.lost for s in skipped if s.lost > 0)
    assert len(got) + known <= len(whole) or any(s.lost < 0 for s in skipped)
    assert all('AssertionError' not in s.reason or 'damaged' in s.reason for s in skipped)


def test_ros1_connection_whose_definition_does_not_parse_fails_only_its_topic(
    tmp_path: Path,
) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 100, bad_definition=True)
    with Bag(path) as bag:
        assert list(bag.topics) == ['/a', '/b', '/c']
        assert sum(1 for _ in bag.messages()) == 200
        assert len(bag.columns('/a')['time']) == 100
        [skipped] = bag.skipped
    assert (skipped.topic, skipped.lost) == ('/c', 10)
    first = min(
        offset for offset, _, found in _ros1_chunks(path) if any(t == '/c' for t, _ in found)
    )
    assert skipped.where == f'byte {first}'  # the first chunk of its messages
    assert 'zros_test/msg/Broken' in skipped.reason and '\n' not in skipped.reason
    with pytest.raises(BagError, match='/c'):
        Bag(path, strict=True)


@pytest.mark.parametrize('name', ['tf_franka.bag', 'tf_example.bag', 'fake_sensors_sample.bag'])
def test_real_ros1_bags_damaged(testdata: Path, tmp_path: Path, name: str) -> None:
    original = testdata / 'ros1' / name
    whole = set(m for _, _, found in _ros1_chunks(original) for m in found)
    data = original.read_bytes()
    path = tmp_path / name
    path.write_bytes(data[: len(data) * 9 // 10])
    try:
        got, skipped = _ros1_read(path)
    except BagError as exc:
        # a one-chunk bag cut inside its chunk holds nothing: said, never an AssertionError
        assert 'no chunk could be read' in str(exc)
    else:
        # cut in the index at the end (tf_franka): every message; else the loss is said
        assert set(got) == whole if not skipped else set(got) < whole
    flipped = bytearray(data)
    rng = random.Random(3)
    for _ in range(4):
        flipped[rng.randrange(len(flipped))] ^= 0x10
    path.write_bytes(bytes(flipped))
    try:
        got, _ = _ros1_read(path)
    except BagError as exc:
        assert 'AssertionError' not in str(exc) or 'damaged' in str(exc)
    else:
        assert len(got) <= len(whole)


def test_damage_is_logged_ten_times_per_topic_then_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    point = encode(new_message('geometry_msgs/msg/Point', x=1.0))
    rows = [(0, stamp, point if stamp % 2 else b'\x00\x01\x00\x00') for stamp in range(40)]
    path = make_db3(tmp_path / 'many.db3', [('/b', 'geometry_msgs/msg/Point')], rows)
    with caplog.at_level(logging.DEBUG, 'zros.bag'), Bag(path) as bag:
        assert sum(1 for _ in bag) == 20
        assert len(bag.skipped) == 20
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 10
    assert 'further damage on /b is counted in Bag.skipped, not logged' in warnings[-1]
    assert sum(1 for r in caplog.records if r.levelno == logging.DEBUG) >= 10


def test_a_zeroed_chunk_and_message_index_lose_an_unknown_count(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    file = make_points_mcap(tmp_path / 'p.mcap', 6100, chunk_size=1 << 16, shuffle=False)
    with file.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    chunk = sorted(summary.chunk_indexes, key=lambda i: i.chunk_start_offset)[2]
    begin = chunk.chunk_start_offset + chunk.chunk_length // 2
    end = chunk.chunk_start_offset + chunk.chunk_length + chunk.message_index_length
    data = bytearray(file.read_bytes())
    data[begin:end] = bytes(end - begin)
    file.write_bytes(bytes(data))
    with Bag(file) as bag:
        assert len(bag.columns('/point')['x']) < 6100
        [skipped] = bag.skipped
    assert (skipped.offset, skipped.topic, skipped.lost) == (chunk.chunk_start_offset, '/point', -1)
    assert 'an unknown number of messages of /point' in str(skipped)


def test_ros1_chunk_of_an_unknown_compression_is_skipped(tmp_path: Path) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 300)
    chunks = _ros1_chunks(path)
    data = path.read_bytes()
    at = data.index(b'compression=none', chunks[2][0])
    path.write_bytes(data[:at] + b'compression=nope' + data[at + 16 :])
    got, skipped = _ros1_read(path)
    assert got == sorted(m for i, (_, _, found) in enumerate(chunks) if i != 2 for m in found)
    assert {(s.offset, s.lost) for s in skipped} == {
        (chunks[2][0], sum(1 for t, _ in chunks[2][2] if t == topic)) for topic in ('/a', '/b')
    }
    assert "compression 'nope' unknown" in skipped[0].reason


def test_a_ros1_bag_with_no_readable_chunk_is_an_error(tmp_path: Path) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 300)
    data = path.read_bytes()
    first = _ros1_chunks(path)[0][0]
    path.write_bytes(data[: first + 20])
    with pytest.raises(BagError, match='no chunk could be read'):
        Bag(path)


def test_bare_assertion_errors_say_what_they_mean() -> None:
    from zros.bag.read.rosbag1_scan import why

    assert (
        why(AssertionError()) == 'the data does not parse, damaged (AssertionError: AssertionError)'
    )
    assert why(KeyError(7)).startswith('the data does not parse, damaged (KeyError')
    assert why(ValueError('a\nb')) == 'a b'


@pytest.mark.parametrize('compression', ['zstd', 'none'])
def test_without_summary_the_scan_goes_on_at_the_next_chunk(
    tmp_path: Path, compression: str
) -> None:
    from mcap.reader import make_reader

    file = make_points_mcap(
        tmp_path / 'p.mcap', 6100, compression, chunk_size=1 << 16, shuffle=False
    )
    whole = sorted((t, s, d) for t, _, s, d in raw_messages(file))
    with file.open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda i: i.chunk_start_offset)
    assert len(chunks) > 3
    damaged = chunks[1]
    lost = _chunk_messages(file, damaged.chunk_start_offset)
    data = bytearray(file.read_bytes()[: chunks[-1].chunk_start_offset + chunks[-1].chunk_length])
    # the chunk's record length: the scan cannot step over it, it has to find the next chunk
    data[damaged.chunk_start_offset + 1 : damaged.chunk_start_offset + 9] = (2**40).to_bytes(
        8, 'little'
    )
    file.write_bytes(bytes(data))
    with Bag(file) as bag:
        got = sorted((r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages())
        [skipped] = bag.skipped
    assert got == sorted(set(whole) - set(lost))
    assert (skipped.offset, skipped.topic, skipped.lost) == (damaged.chunk_start_offset, '', -1)
    assert f'read on at byte {chunks[2].chunk_start_offset}' in skipped.reason


def test_garbage_rows_in_a_real_db3(testdata: Path, tmp_path: Path) -> None:
    import sqlite3

    folder = tmp_path / 'tf'
    shutil.copytree(testdata / 'ros2' / 'tf_example_db3', folder)
    [file] = folder.glob('*.db3')
    with Bag(folder) as bag:
        whole = sum(1 for _ in bag)
        topic_of = {c.id: c.topic for c in bag.connections}
    db = sqlite3.connect(file)
    try:
        rows = [row for (row,) in db.execute('SELECT id FROM messages ORDER BY id')][5::50]
        db.executemany(
            'UPDATE messages SET data = ? WHERE id = ?',
            [(b'\x00\x01\x00\x00' + bytes(3), row) for row in rows],
        )
        db.commit()
    finally:
        db.close()
    with Bag(folder) as bag:
        assert sum(1 for _ in bag) == whole - len(rows)
        assert sorted(s.row for s in bag.skipped) == rows
        assert {s.file for s in bag.skipped} == {file}
        assert {s.topic for s in bag.skipped} <= set(topic_of.values())
    with pytest.raises(BagError, match=f'row {rows[0]}'):
        bag_read(folder, strict=True)


def test_a_real_one_chunk_mcap_damaged_reads_its_start_and_says_so(
    testdata: Path, tmp_path: Path
) -> None:
    folder = tmp_path / 'nav2'
    shutil.copytree(testdata / 'ros2' / 'tf_nav2_mcap', folder)
    [file] = folder.glob('*.mcap')
    whole = len(raw_messages(file))
    in_order = _chunk_messages(file, 58)  # its one chunk
    assert len(in_order) == whole
    data = bytearray(file.read_bytes())
    data[249856 : 249856 + 4096] = bytes(4096)  # zstd stops there: 1.96 MB of 2.96 MB before
    file.write_bytes(bytes(data))
    for path in (folder, file):
        with Bag(path) as bag:
            got = _read(bag)
            assert sorted(in_order[: len(got)]) == got  # equal to the intact file's
            assert sum(s.lost for s in bag.skipped) == whole - len(got)
            assert {s.offset for s in bag.skipped} == {58}
            assert all(
                'Data corruption detected; its messages in its first ' in s.reason
                for s in bag.skipped
            )
        assert len(got) == 4698  # two zstd blocks before where it fails are not trusted
    [report] = reindex(file, backup=False).files  # through the linear scan
    assert (report.message_count, report.lost_messages) == (4698, whole - 4698)
    with Bag(file) as bag:
        assert _read(bag) == got


def test_ros1_scan_with_a_damaged_connection_record_loses_only_its_messages(
    tmp_path: Path,
) -> None:
    path = make_ros1_bag(tmp_path / 'r.bag', 300)
    chunks = _ros1_chunks(path)
    data = path.read_bytes()
    cut = chunks[-1][1]  # after the last chunk: the index and the connections at the end gone
    first = data.index(b'type=std_msgs/String', chunks[0][0])  # /a's record, in chunk 1
    data = data[:first] + b'typo' + data[first + 4 : cut]
    path.write_bytes(data)
    got, skipped = _ros1_read(path)
    assert got == sorted(m for _, _, found in chunks for m in found if m[0] == '/b')
    [lost] = skipped
    assert (lost.topic, lost.lost) == ('', 300)
    assert 'the record of connection' in lost.reason


def _zero_a_page(path: Path) -> None:
    data = bytearray(path.read_bytes())
    page = 4096
    middle = len(data) // 2 // page * page
    data[middle : middle + page] = bytes(page)
    path.write_bytes(bytes(data))


def test_a_db3_with_a_zeroed_page_reads_every_other_row(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    texts = [
        encode(new_message('std_msgs/msg/String', data='x' * 200 + str(i))) for i in range(5000)
    ]
    path = make_db3(
        tmp_path / 'paged.db3',
        [('/a', 'std_msgs/msg/String')],
        [(0, 1000 + i, text) for i, text in enumerate(texts)],
    )
    _zero_a_page(path)
    with caplog.at_level(logging.WARNING, 'zros.bag'), Bag(path) as bag:
        got = [(stamp, encode(m)) for _, stamp, m in bag.messages()]
        skipped = bag.skipped
        assert len(bag.columns('/a')['time']) == len(got)
    # a run of rows lost is one entry and one warning, after the one saying how it is read
    rows = [row for s in skipped if s.row is not None for row in range(s.row, s.row + s.lost)]
    assert 0 < len(rows) < 100 and all(s.file == path for s in skipped)
    warnings = [r.getMessage() for r in caplog.records]
    assert 'read row by row' in warnings[0]
    assert warnings[1:] == [
        f'{path}: skipped the damaged data at row {s.row} '
        f'({f"rows {s.row} to {s.row + s.lost - 1} do not read" if s.lost > 1 else "the row does not read"}): '
        f'lost {s.lost} message{"s" if s.lost > 1 else ""} of unknown topics'
        for s in skipped
    ]
    # the rows that read are the originals, the others are counted by row id (row i is message
    # i - 1): every message is one or the other
    assert got == [(1000 + i, text) for i, text in enumerate(texts) if i + 1 not in rows]
    with pytest.raises(BagError, match=f'row {rows[0]}'):
        Bag(path, strict=True)


def test_a_real_db3_with_a_zeroed_page(testdata: Path, tmp_path: Path) -> None:
    original = testdata / 'ros2' / 'tf_franka_db3' / 'rosbagFrankaPandaRos2.bag.db3'
    path = tmp_path / original.name
    shutil.copy(original, path)
    whole = {(t, s, d) for t, _, s, d in raw_messages(original)}
    _zero_a_page(path)
    with Bag(path) as bag:
        got = {(r.connection.topic, r.timestamp, bytes(r.data)) for r in bag.raw_messages()}
        lost = sum(s.lost for s in bag.skipped)
    assert got <= whole
    assert lost > 0 and len(got) + lost == len(whole)


def _overlapping_mcap(path: Path, count: int) -> Path:
    """Two topics written one after the other (as a merge of two recordings): every chunk of
    /b overlaps chunks of /a in time."""
    from mcap.writer import CompressionType, Writer

    with path.open('wb') as stream:
        writer = Writer(stream, chunk_size=1 << 12, compression=CompressionType.ZSTD)
        writer.start(profile='ros2', library='zros tests')
        schema = writer.register_schema(
            'geometry_msgs/msg/Point', 'ros2msg', b'float64 x\nfloat64 y\nfloat64 z\n'
        )
        for topic, shift in (('/a', 0), ('/b', 5)):
            channel = writer.register_channel(topic, 'cdr', schema)
            for index in range(count):
                data = encode(new_message('geometry_msgs/msg/Point', x=index, y=shift, z=0.5))
                stamp = 1000 + index * 10 + shift
                writer.add_message(channel, log_time=stamp, data=data, publish_time=stamp)
        writer.finish()
    return path


def test_a_damaged_chunk_among_chunks_that_overlap_in_time(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    file = _overlapping_mcap(tmp_path / 'merged.mcap', 3000)
    whole = sorted((t, s, d) for t, _, s, d in raw_messages(file))
    with Bag(file) as bag:  # intact: one time order across both topics' chunks
        stamps = [stamp for _, stamp, _ in bag.messages()]
    assert stamps == sorted(stamps) and len(stamps) == 6000
    offset, lost = zero_a_chunk(file)
    _check_mcap(file, file, offset=offset, whole=whole, lost=lost, caplog=caplog)
    with Bag(file) as bag:
        stamps = [stamp for _, stamp, _ in bag.messages()]
    assert stamps == sorted(stamps) and len(stamps) == 6000 - len(lost)


def test_damage_of_unknown_topics_names_them_when_no_longer_logged(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from zros.bag.read.damage import Damage

    damage = Damage()
    with caplog.at_level(logging.WARNING, 'zros.bag'):
        for offset in range(12):
            damage.report([Skipped(tmp_path, offset, None, '', -1, 'cut')])
    warnings = [r.getMessage() for r in caplog.records]
    assert len(warnings) == 10 and len(damage.skipped) == 12
    assert warnings[-1].endswith(
        'lost an unknown number of messages of unknown topics; further damage on unknown '
        'topics is counted in Bag.skipped, not logged'
    )
