"""The raw layer: every recording opens, and its messages are the bytes rosbags reads."""

from __future__ import annotations

import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.bag.makebags import make_points_mcap, make_schema_mcap
from tests.bag.reference import RECORDINGS, raw_messages, to_plain
from zros.bag import Bag, BagError, Connection, open_source
from zros.bag.read import source
from zros.bag.read.source import Source, normalise_type_name


@pytest.mark.parametrize('name', RECORDINGS)
def test_messages_are_what_rosbags_reads(testdata: Path, name: str) -> None:
    path = testdata / name
    expected = raw_messages(path)
    with open_source(path) as source:
        got = list(source.messages())
        assert source.message_count == len(expected)
        counts = {c.topic: 0 for c in source.connections}
        for message in got:
            counts[message.connection.topic] += 1
        assert {c.topic: c.count for c in source.connections} == counts
        if expected:
            assert source.start_ns == expected[0][2]
            assert source.end_ns == expected[-1][2]
        else:
            assert (source.start_ns, source.end_ns) == (0, 0)
    assert [m.timestamp for m in got] == [e[2] for e in expected]
    # equal timestamps may come in either order: compare as sorted groups
    mine = sorted((m.timestamp, m.connection.topic, bytes(m.data)) for m in got)
    theirs = sorted((e[2], e[0], e[3]) for e in expected)
    if path.suffix == '.bag':
        # ROS 1 bytes become CDR: compare topics and times here, content in test_reader
        assert [m[:2] for m in mine] == [t[:2] for t in theirs]
    else:
        assert mine == theirs
        types = {(m.connection.topic, m.connection.type_name) for m in got}
        assert types == {(e[0], normalise_type_name(e[1])) for e in expected}


def test_split_bag_lists_every_file_and_merges_in_time_order(testdata: Path) -> None:
    with open_source(testdata / 'ros2' / 'wbag_split_mcap') as source:
        assert [f.name for f in source.files] == [
            'metadata.yaml',
            *[f'wbag_{i}.mcap' for i in range(5)],
        ]
        assert source.size_bytes == sum(f.stat().st_size for f in source.files)
        stamps = [m.timestamp for m in source.messages()]
        assert stamps == sorted(stamps)
        assert source.storage_id == 'mcap'
        # metadata.yaml of this bag says it starts at 2623; the files say 1000
        assert source.start_ns == 1000


def test_filters_by_connection_and_time(testdata: Path) -> None:
    with open_source(testdata / 'ros2' / 'talker_mcap') as source:
        rosout = next(c for c in source.connections if c.topic == '/rosout')
        every = list(source.messages([rosout]))
        assert len(every) == 10
        assert {m.connection.topic for m in every} == {'/rosout'}
        start, end = every[2].timestamp, every[5].timestamp
        window = list(source.messages([rosout], start=start, end=end))
        assert [m.timestamp for m in window] == [m.timestamp for m in every[2:5]]
        assert list(source.messages([])) == []


def test_connections_carry_definitions_qos_and_legacy_names(testdata: Path) -> None:
    with open_source(testdata / 'ros2' / 'legacy_type_names_mcap') as source:
        (conn,) = source.connections
        assert conn.type_name == 'test_msgs/msg/BasicTypes'
        assert conn.definition_format == 'ros2msg'
        assert 'float64 float64_value' in conn.definition
    with open_source(testdata / 'ros2' / 'services_and_topics' / 'topics_and_services.db3') as src:
        events = [c for c in src.connections if c.type_name.endswith('_Event')]
        # the db3 keeps the definition under the service's name
        assert events and all('---' in c.definition for c in events)
        assert all('reliability' in c.qos for c in src.connections)
    with open_source(testdata / 'ros1' / 'fake_sensors_sample.bag') as source:
        temperature = next(c for c in source.connections if c.topic == '/my_temperature')
        assert temperature.serialization == 'cdr'
        assert 'seq' not in temperature.definition


def test_ros1_messages_are_cdr_without_the_header_seq(testdata: Path) -> None:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    path = testdata / 'ros1' / 'fake_sensors_sample.bag'
    with AnyReader([path]) as reader:
        theirs = [to_plain(reader.deserialize(d, c.msgtype)) for c, _, d in reader.messages()]
    for message in theirs:
        assert 'seq' in message['header']
        del message['header']['seq']
    with open_source(path) as source:
        mine = [
            to_plain(store.deserialize_cdr(bytes(m.data), m.connection.type_name))
            for m in source.messages()
        ]
    assert mine == theirs


def test_closed_source_refuses_to_read(testdata: Path) -> None:
    source = open_source(testdata / 'ros2' / 'talker_mcap')
    source.close()
    source.close()
    with pytest.raises(BagError, match='closed'):
        list(source.messages())


def test_foreign_connection_is_refused(testdata: Path) -> None:
    with (
        open_source(testdata / 'ros2' / 'talker_mcap') as one,
        open_source(testdata / 'ros2' / 'cdr_test_mcap') as other,
        pytest.raises(ValueError, match='not a connection'),
    ):
        list(one.messages(other.connections))


# --- bad input --------------------------------------------------------------------------------


def test_missing_path(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='no such file') as info:
        open_source(tmp_path / 'nothing.mcap')
    assert info.value.path == tmp_path / 'nothing.mcap'


def test_folder_without_metadata(tmp_path: Path) -> None:
    with pytest.raises(BagError, match=r'no metadata\.yaml'):
        open_source(tmp_path)


@pytest.mark.parametrize('name', ['notes.txt', 'fake.mcap', 'fake.db3', 'fake.bag'])
def test_not_a_bag(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(b'this is not a recording\n' * 10)
    with pytest.raises(BagError, match=re.escape(path.name)):
        open_source(path)


def test_unknown_format_names_the_known_ones(tmp_path: Path) -> None:
    path = tmp_path / 'notes.txt'
    path.write_text('no bag here')
    with pytest.raises(BagError) as info:
        open_source(path)
    assert info.value.path == path
    assert info.value.reason == (
        'not a recording zros reads (expected a bag folder, .mcap, .db3 or ROS 1 .bag)'
    )


def test_a_format_is_one_table_entry(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A reader registered in ``FORMATS`` opens the paths its detector accepts, and is named in
    the error for paths no format accepts."""

    class Notes(Source):
        def open(self) -> None:
            self.storage_id = 'notes'
            self.files = [self.path]

    formats = {
        **source.FORMATS,
        'notes': source.Format(lambda p: p.suffix == '.txt', Notes, '.txt'),
    }
    monkeypatch.setattr(source, 'FORMATS', formats)
    path = tmp_path / 'notes.txt'
    path.write_text('no bag here')
    with open_source(path) as opened:
        assert isinstance(opened, Notes)
        assert opened.storage_id == 'notes'
    other = tmp_path / 'notes.csv'
    other.write_text('')
    with pytest.raises(BagError, match=r'\.db3 or ROS 1 \.bag or \.txt\)$'):
        open_source(other)


def test_a_reader_that_fails_to_open_is_closed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    closed: list[Path] = []

    class Broken(Source):
        def open(self) -> None:
            self._closers.append(lambda: closed.append(self.path))
            raise OSError('the disk is gone')

    monkeypatch.setattr(source, 'FORMATS', {'broken': source.Format(lambda p: True, Broken, 'any')})
    path = tmp_path / 'x.broken'
    path.write_text('')
    with pytest.raises(BagError, match='cannot open the recording: the disk is gone'):
        open_source(path)
    assert closed == [path]


def test_empty_file(tmp_path: Path) -> None:
    path = tmp_path / 'empty.mcap'
    path.write_bytes(b'')
    with pytest.raises(BagError, match='empty'):
        open_source(path)


@pytest.mark.parametrize(
    ('name', 'size'),
    [
        ('ros2/services_and_topics/topics_and_services.db3', None),
        ('ros1/fake_sensors_sample.bag', 4130),  # inside its one chunk's header (half reads)
    ],
)
def test_truncated_file(testdata: Path, tmp_path: Path, name: str, size: int | None) -> None:
    original = testdata / name
    path = tmp_path / original.name
    path.write_bytes(original.read_bytes()[: size or original.stat().st_size // 2])
    with pytest.raises(BagError, match=re.escape(path.name)), open_source(path) as source:
        list(source.messages())


def linear_scan(path: Path) -> list[tuple[int, bytes]]:
    """(time, data) of the messages in an MCAP file's complete records: the mcap library's
    stream reader up to the first record cut short."""
    from mcap.records import Message
    from mcap.stream_reader import StreamReader

    found = []
    with path.open('rb') as stream:
        try:
            for record in StreamReader(stream, validate_crcs=True).records:
                if isinstance(record, Message):
                    found.append((record.log_time, record.data))
        except Exception:
            pass
    return sorted(found, key=lambda item: item[0])


def test_truncated_mcap_is_read_up_to_its_last_complete_chunk(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = make_points_mcap(tmp_path / 'points.mcap', 400, 'zstd', shuffle=False)
    path.write_bytes(path.read_bytes()[: path.stat().st_size * 3 // 5])
    expected = linear_scan(path)
    assert 0 < len(expected) < 400
    with open_source(path) as source:
        got = [(m.timestamp, bytes(m.data)) for m in source.messages()]
        assert source.message_count == len(expected)
        assert source.connections[0].type_name == 'geometry_msgs/msg/Point'
        assert source.start_ns == expected[0][0] and source.end_ns == expected[-1][0]
    assert got == expected
    assert 'up to its last complete record' in caplog.text
    with Bag(path) as bag:
        assert bag.columns('/point', ['x'])['x'].tolist() == list(range(len(expected)))


@pytest.mark.parametrize('metadata', [True, False])
def test_unfinished_split_bag(
    testdata: Path, tmp_path: Path, metadata: bool, caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / 'wbag'
    shutil.copytree(testdata / 'ros2' / 'wbag_split_mcap', folder)
    if not metadata:
        (folder / 'metadata.yaml').unlink()
    last = folder / 'wbag_4.mcap'
    # its one chunk spans bytes 45 to 7494: cut it in the middle
    last.write_bytes(last.read_bytes()[:3000])
    whole = [(t, d) for i in range(4) for _, _, t, d in raw_messages(folder / f'wbag_{i}.mcap')]
    assert linear_scan(last) == []
    expected = whole
    with open_source(folder) as source:
        got = sorted((m.timestamp, bytes(m.data)) for m in source.messages())
        assert [f.name for f in source.files][-5:] == [f'wbag_{i}.mcap' for i in range(5)]
        assert source.message_count == len(expected) == 6074 - 1108
    assert got == sorted(expected)
    assert 'wbag_4.mcap: no complete record, skipped' in caplog.text


def test_folder_without_recordings(tmp_path: Path) -> None:
    (tmp_path / 'notes.txt').write_text('no bag here')
    with pytest.raises(BagError, match=r'no \.mcap or \.db3 file') as info:
        open_source(tmp_path)
    assert str(info.value).count(str(tmp_path)) == 1


def test_metadata_naming_a_missing_file(testdata: Path, tmp_path: Path) -> None:
    folder = tmp_path / 'bag'
    shutil.copytree(testdata / 'ros2' / 'talker_mcap', folder)
    (folder / 'talker.mcap').unlink()
    with pytest.raises(BagError, match='missing'):
        open_source(folder)


def test_corrupt_record_length_is_an_error_not_an_allocation(
    testdata: Path, tmp_path: Path
) -> None:
    original = testdata / 'ros2' / 'padded_mcap' / 'multiple_files_2.mcap'
    data = bytearray(original.read_bytes())
    # the header record's length (after 8 magic bytes and the opcode): claim 2**62 bytes
    data[9:17] = (2**62).to_bytes(8, 'little')
    path = tmp_path / 'corrupt.mcap'
    path.write_bytes(bytes(data))
    past_the_end = (
        "the header record at byte 8 declares 4611686018427387904 bytes, past the file's end"
    )
    with pytest.raises(BagError, match=rf'corrupt\.mcap: .*{past_the_end}'):
        open_source(path, strict=True)
    # the scan goes on at the chunk after it: every message reads
    with open_source(path) as source:
        got = [(m.timestamp, bytes(m.data)) for m in source.messages()]
        [skipped] = source.damage.skipped
    assert got == [(e[2], e[3]) for e in raw_messages(original)]
    assert skipped.offset == 8 and past_the_end in skipped.reason


@pytest.mark.parametrize('mode', ['MESSAGE', 'FILE'])
@pytest.mark.parametrize('storage', ['MCAP', 'SQLITE3'])
def test_compressed_bags(tmp_path: Path, mode: str, storage: str) -> None:
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, Reader, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from zros.cdr import encode, new_message

    store = get_typestore(Stores.ROS2_JAZZY)
    path = tmp_path / 'compressed'
    writer = Writer(path, version=9, storage_plugin=StoragePlugin[storage])
    writer.set_compression(CompressionMode[mode], CompressionFormat.ZSTD)
    with writer:
        conn = writer.add_connection('/text', 'std_msgs/msg/String', typestore=store)
        for index in range(30):
            text = new_message('std_msgs/msg/String', data=f'message {index}')
            writer.write(conn, 1000 + index, encode(text))
    with Reader(path) as reader:
        expected = [(t, bytes(d)) for _, t, d in reader.messages()]
    with open_source(path) as source:
        assert source.compression_mode == mode.lower()
        assert source.compression_format == 'zstd'
        assert [(m.timestamp, bytes(m.data)) for m in source.messages()] == expected
        names = [f.name for f in source.files]
    assert names[0] == 'metadata.yaml'
    assert all((path / name).exists() for name in names)
    if mode == 'FILE':
        assert names[1].endswith('.zstd')


def _counting_fast_path(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Count the messages the whole-chunk MCAP reader gives (the loop's fast path)."""
    from zros.bag.read import mcap_chunks, rosbag2

    given = [0]
    original = mcap_chunks.ordered_messages

    def counted(*args: Any) -> Iterator[tuple[Connection, int, bytes]]:
        for item in original(*args):
            given[0] += 1
            yield item

    monkeypatch.setattr(rosbag2, 'ordered_messages', counted)
    return given


@pytest.mark.parametrize('compression', ['zstd', 'none'])
@pytest.mark.parametrize('shuffle', [False, True])
def test_mcap_messages_by_whole_chunks_equal_rosbags(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, compression: str, shuffle: bool
) -> None:
    path = make_points_mcap(tmp_path / 'p.mcap', 300, compression, shuffle=shuffle)
    given = _counting_fast_path(monkeypatch)
    expected = [(e[2], e[3]) for e in raw_messages(path)]
    with open_source(path) as source:
        got = [(m.timestamp, bytes(m.data)) for m in source.messages()]
        window = [(m.timestamp, bytes(m.data)) for m in source.messages(None, 1500, 2500)]
    assert got == expected
    assert window == [e for e in expected if 1500 <= e[0] < 2500]
    assert given[0] == len(got) + len(window)  # chunks in time order are read whole


def test_mcap_chunks_overlapping_in_time_are_merged_as_rosbags_orders_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcap.writer import Writer

    from zros.cdr import encode, new_message

    path = tmp_path / 'overlap.mcap'
    with path.open('wb') as stream:
        writer = Writer(stream, chunk_size=1024)
        writer.start(profile='ros2', library='zros tests')
        schema = writer.register_schema('std_msgs/msg/Int32', 'ros2msg', b'int32 data\n')
        channel = writer.register_channel('/n', 'cdr', schema)
        for index in range(400):  # the second half goes back in time, between the first's
            stamp = 1000 + 10 * index if index < 200 else 1005 + 10 * (index - 200)
            data = encode(new_message('std_msgs/msg/Int32', data=index))
            writer.add_message(channel, log_time=stamp, data=data, publish_time=stamp)
        writer.finish()
    given = _counting_fast_path(monkeypatch)
    expected = [(e[2], e[3]) for e in raw_messages(path)]
    with open_source(path) as source:
        got = [(m.timestamp, bytes(m.data)) for m in source.messages()]
    assert got == expected
    assert [t for t, _ in got] == sorted(t for t, _ in got)
    assert given[0] == 400  # by the chunk reader, which skips a damaged chunk (rosbags stops)


def test_a_chunk_index_failing_midway_hands_over_to_rosbags_without_loss_or_repeats(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.bag.read import mcap_chunks

    path = make_points_mcap(tmp_path / 'p.mcap', 300, 'none', shuffle=False)
    given = _counting_fast_path(monkeypatch)
    original = mcap_chunks._block
    calls = [0]

    def third_fails(*args: Any) -> mcap_chunks._Run:
        calls[0] += 1
        if calls[0] == 3:
            raise mcap_chunks.Unsupported('message index does not match the chunk')
        return original(*args)

    monkeypatch.setattr(mcap_chunks, '_block', third_fails)
    expected = [(e[2], e[3]) for e in raw_messages(path)]
    with open_source(path) as source:
        got = [(m.timestamp, bytes(m.data)) for m in source.messages()]
    assert 0 < given[0] < len(expected)
    assert got == expected


def test_a_schema_encoding_no_ros_reader_reads_is_no_damage(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    import logging

    from zros.bag import UndecodedMessage

    thing, text = b'\x00\x01\x00\x00abcd', b'\x00\x01\x00\x00\x02\x00\x00\x00a\x00'
    path = make_schema_mcap(
        tmp_path / 'unknown.mcap',
        [
            ('/thing', 'pkg/msg/Thing', 'unknown', b'whatever'),
            ('/chatter', 'std_msgs/msg/String', 'ros2msg', b'string data'),
        ],
        [row for n in range(3) for row in ((0, n, thing), (1, n, text))],
    )
    with caplog.at_level(logging.DEBUG, 'zros.bag'), Bag(path) as bag:
        found = list(bag.messages())
        assert bag.skipped == []
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1, warnings  # not "do not open as complete MCAP … (no summary)"
    assert (
        "/thing) has its definition in schema encoding 'unknown', which zros does not read"
        in (warnings[0])
    )
    things = [message for topic, _, message in found if topic == '/thing']
    assert len(things) == 3 and all(isinstance(m, UndecodedMessage) for m in things)
    assert things[0].data == b'\x00\x01\x00\x00abcd'
    assert [m.data for topic, _, m in found if topic == '/chatter'] == ['a'] * 3
    with Bag(path) as bag, pytest.raises(BagError, match="schema encoding 'unknown'"):
        bag.columns('/thing')
