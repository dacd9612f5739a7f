"""Recording live topics: everything arrives, in rosbag2's MCAP layout, readable by others."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import zros
from zros.bag.errors import BagWriteError, RecorderError
from zros.bag.read.rosbag2_yaml import parse_qos_profiles
from zros.bag.write.mcap_writer import McapFile
from zros.bag.write.recorder import Recorder, is_hidden, recording_qos
from zros.cdr import TypeRegistry, default_registry, encode
from zros.cdr.render import render_bundle
from zros.qos import Durability, History, QoS, Reliability
from zros.testing import wait_for

Node = Callable[..., Any]
STRING = 'std_msgs/msg/String'
STRING_HASH = 'RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18'


# --- readers used as references ----------------------------------------------------------------


def read_rosbags(path: Path) -> list[tuple[str, int, Any]]:
    """(topic, timestamp, message) of every message, as rosbags' AnyReader decodes them."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        return [
            (connection.topic, stamp, reader.deserialize(raw, connection.msgtype))
            for connection, stamp, raw in reader.messages()
        ]


def read_mcap(path: Path) -> list[tuple[Any, Any, Any, Any]]:
    """(schema, channel, message record, decoded) of every message of every file of a bag,
    decoded by the mcap library's ROS 2 support (its own parser of the schema text)."""
    from mcap.reader import make_reader

    decoder = pytest.importorskip('mcap_ros2.decoder')
    found = []
    for file in sorted(path.glob('*.mcap')):
        with file.open('rb') as stream:
            reader = make_reader(stream, decoder_factories=[decoder.DecoderFactory()])
            assert reader.get_header().profile == 'ros2'
            found.extend(reader.iter_decoded_messages(log_time_order=False))
    return found


def bag_yaml(path: Path) -> dict[str, Any]:
    from ruamel.yaml import YAML

    loaded: dict[str, Any] = YAML(typ='safe').load((path / 'metadata.yaml').read_text())
    return loaded['rosbag2_bagfile_information']


def publish_in_threads(publishers: list[Any], count: int) -> None:
    """Publish ``count`` strings ``'<topic index>:<n>'`` on each publisher, all at once."""

    def run(index: int) -> None:
        cls = publishers[index].msg_type
        for n in range(count):
            publishers[index].write(cls(data=f'{index}:{n}'))

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(publishers))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()


# --- the acceptance run ------------------------------------------------------------------------


def test_records_100000_messages_on_5_topics(zros_node: Node, tmp_path: Path) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    topics = [f'/stream{i}' for i in range(5)]
    publishers = [talker.create_publisher(STRING, t, 'keep_all') for t in topics]
    path = tmp_path / 'run'
    began = time.time_ns()
    recorder = Recorder(recording, path, all=True)
    assert recorder.wait_for_topics(topics, 10)
    for publisher in publishers:
        assert publisher.wait_for_subscribers()
    publish_in_threads(publishers, 20_000)
    assert wait_for(lambda: recorder.message_count >= 100_000, 120), recorder.message_count
    recorder.close()
    ended = time.time_ns()
    assert recorder.message_count == 100_000
    assert recorder.files == [path / 'run_0.mcap']

    # rosbags: every message, in order per topic, timestamps monotonic inside the window
    messages = read_rosbags(path)
    assert len(messages) == 100_000
    stamps = [stamp for _, stamp, _ in messages]
    assert stamps == sorted(stamps)
    assert began <= stamps[0] and stamps[-1] <= ended
    next_of: dict[str, int] = {}
    for topic, _, message in messages:
        index, n = map(int, message.data.split(':'))
        assert topic == topics[index]
        assert next_of.get(topic, 0) == n
        next_of[topic] = n + 1
    assert next_of == dict.fromkeys(topics, 20_000)

    # mcap: schemas, channel metadata, publish times from the source, decoding
    records = read_mcap(path)
    assert len(records) == 100_000
    schema, channel, _, decoded = records[-1]
    assert (schema.name, schema.encoding) == (STRING, 'ros2msg')
    assert schema.data.decode() == render_bundle(default_registry(), STRING)
    assert channel.message_encoding == 'cdr'
    assert channel.metadata['topic_type_hash'] == STRING_HASH
    assert parse_qos_profiles(channel.metadata['offered_qos_profiles']) == [
        QoS(10, history=History.KEEP_ALL)
    ]
    assert decoded.data.startswith(channel.topic[-1] + ':')
    for _, _, record, _ in records:  # sent (the source's time) before received, in the window
        assert began <= record.publish_time <= record.log_time

    info = bag_yaml(path)
    assert info['version'] == 8
    assert info['storage_identifier'] == 'mcap'
    assert info['message_count'] == 100_000
    assert info['relative_file_paths'] == ['run_0.mcap']
    assert info['starting_time']['nanoseconds_since_epoch'] == stamps[0]
    assert info['duration']['nanoseconds'] == stamps[-1] - stamps[0]
    counts = {
        t['topic_metadata']['name']: t['message_count'] for t in info['topics_with_message_count']
    }
    assert {name: counts[name] for name in topics} == dict.fromkeys(topics, 20_000)
    assert sum(counts.values()) == 100_000  # the other topics (/parameter_events) were quiet


# --- discovery and selection -------------------------------------------------------------------


def test_all_records_topics_that_appear_later_but_not_hidden_ones(
    zros_node: Node, tmp_path: Path
) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    early = talker.create_publisher(STRING, '/early')
    recorder = Recorder(recording, tmp_path / 'bag', all=True)
    assert recorder.wait_for_topics(['/early'])
    late = talker.create_publisher('std_msgs/msg/Int32', '/late')
    hidden = talker.create_publisher(STRING, '/robot/_internal')
    assert recorder.wait_for_topics(['/late'])
    assert early.wait_for_subscribers() and late.wait_for_subscribers()
    for publisher, value in ((early, 'a'), (late, 7), (hidden, 'h')):
        publisher.write(publisher.msg_type(data=value))
    assert wait_for(lambda: recorder.message_count == 2)
    recorder.close()
    assert '/robot/_internal' not in recorder.topics
    got = {(topic, message.data) for topic, _, message in read_rosbags(tmp_path / 'bag')}
    assert got == {('/early', 'a'), ('/late', 7)}


def test_regex_and_names_select_topics(zros_node: Node, tmp_path: Path) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    for name in ('/camera/image', '/camera/info', '/odom', '/tf', '/_hidden/camera'):
        talker.create_publisher(STRING, name)
    seen: list[tuple[str, str]] = []
    recorder = Recorder(
        recording, tmp_path / 'bag', ['tf'], regex='^/camera/', on_topic=lambda *t: seen.append(t)
    )
    assert recorder.wait_for_topics(['/camera/image', '/camera/info', '/tf'])
    talker.create_publisher(STRING, '/camera/depth')  # matches, appears later
    assert recorder.wait_for_topics(['/camera/depth'])
    recorder.close()
    expected = {'/camera/image', '/camera/info', '/camera/depth', '/tf'}
    assert set(recorder.topics) == expected
    assert {name for name, _ in seen} == expected
    info = bag_yaml(tmp_path / 'bag')
    assert {t['topic_metadata']['name'] for t in info['topics_with_message_count']} == expected


def test_named_topic_is_recorded_once_it_appears(zros_node: Node, tmp_path: Path) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    recorder = Recorder(recording, tmp_path / 'bag', ['/later'])
    assert not recorder.wait_for_topics(['/later'], 0.3)
    publisher = talker.create_publisher(STRING, '/later')
    assert recorder.wait_for_topics(['/later'])
    assert publisher.wait_for_subscribers()
    publisher.write(publisher.msg_type(data='finally'))
    assert wait_for(lambda: recorder.message_count == 1)
    recorder.close()
    assert [m.data for _, _, m in read_rosbags(tmp_path / 'bag')] == ['finally']


def test_latched_messages_published_before_recording_are_recorded(
    zros_node: Node, tmp_path: Path
) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    publisher = talker.create_publisher(STRING, '/map_name', 'latched')
    publisher.write(publisher.msg_type(data='first floor'))
    with Recorder(recording, tmp_path / 'bag', ['/map_name']) as recorder:
        assert wait_for(lambda: recorder.message_count == 1)
    channel = read_mcap(tmp_path / 'bag')[0][1]
    (offered,) = parse_qos_profiles(channel.metadata['offered_qos_profiles'])
    assert offered.durability is Durability.TRANSIENT_LOCAL
    assert [m.data for _, _, m in read_rosbags(tmp_path / 'bag')] == ['first floor']


def test_recording_qos_adapts_to_the_publishers() -> None:
    latched = QoS(1, durability=Durability.TRANSIENT_LOCAL)
    assert recording_qos([latched, latched]) == latched
    mixed = recording_qos([latched, QoS(20, Reliability.BEST_EFFORT)])
    assert mixed == QoS(20, Reliability.BEST_EFFORT)
    assert recording_qos([]) == QoS(10)
    assert is_hidden('/a/_b') and not is_hidden('/a/b_')


def test_unknown_types_are_recorded_without_a_schema(
    zros_node: Node, zros_transport: Callable[..., Any], tmp_path: Path
) -> None:
    mine = TypeRegistry()
    mine.register_text('my_pkg/msg/Blip', 'int32 level\n')
    talker = zros_node('talker', registry=mine)
    recording = zros_node('recording')
    publisher = talker.create_publisher('my_pkg/msg/Blip', '/blips')
    with Recorder(recording, tmp_path / 'bag', ['/blips']) as recorder:
        assert recorder.wait_for_topics(['/blips'])
        assert publisher.wait_for_subscribers()
        publisher.write(publisher.msg_type(level=3))
        assert wait_for(lambda: recorder.message_count == 1)
    from mcap.reader import make_reader

    with (tmp_path / 'bag' / 'bag_0.mcap').open('rb') as stream:
        reader = make_reader(stream)
        ((schema, channel, record),) = list(reader.iter_messages())
    assert (schema.name, schema.encoding, schema.data) == ('my_pkg/msg/Blip', '', b'')
    assert channel.metadata['topic_type_hash'] == ''
    assert record.data == encode(publisher.msg_type(level=3))


def test_sim_time_stamps_messages_with_clock_time(zros_node: Node, tmp_path: Path) -> None:
    talker = zros_node('talker')
    recording = zros_node('recording', use_sim_time=True)
    clock = talker.create_publisher('rosgraph_msgs/msg/Clock', '/clock')
    assert clock.wait_for_subscribers()
    tick = clock.msg_type()
    tick.clock.sec = 1234
    clock.write(tick)
    assert wait_for(lambda: recording.now().nanoseconds == 1234 * 10**9)
    publisher = talker.create_publisher(STRING, '/sim')
    with Recorder(recording, tmp_path / 'bag', ['/sim']) as recorder:
        assert recorder.wait_for_topics(['/sim'])
        assert publisher.wait_for_subscribers()
        publisher.write(publisher.msg_type(data='x'))
        assert wait_for(lambda: recorder.message_count == 1)
    ((_, _, record, _),) = read_mcap(tmp_path / 'bag')
    assert record.log_time == record.publish_time == 1234 * 10**9


# --- splitting and compression -----------------------------------------------------------------


@pytest.mark.parametrize('compression', ['zstd', 'lz4', None])
def test_split_by_size_names_files_and_lists_them(
    zros_node: Node, tmp_path: Path, compression: str | None
) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    publisher = talker.create_publisher(STRING, '/chatter', 'keep_all')
    path = tmp_path / 'split'
    recorder = Recorder(
        recording, path, ['/chatter'], split_size=20_000, compression=compression, chunk_size=4096
    )
    assert recorder.wait_for_topics(['/chatter'])
    assert publisher.wait_for_subscribers()
    for n in range(2000):
        publisher.write(publisher.msg_type(data=f'message {n:05d} ' + 'x' * (n % 50)))
    assert wait_for(lambda: recorder.message_count == 2000, 30)
    recorder.close()
    files = sorted(path.glob('*.mcap'))
    assert len(files) >= 3
    assert files == [path / f'split_{i}.mcap' for i in range(len(files))]
    info = bag_yaml(path)
    assert info['relative_file_paths'] == [f.name for f in files]
    assert [f['path'] for f in info['files']] == [f.name for f in files]
    assert sum(f['message_count'] for f in info['files']) == 2000
    for file in files[:-1]:  # a file is split once it reaches the size, not long after
        assert 20_000 <= file.stat().st_size < 20_000 + 12_000
    got = [m.data for _, _, m in read_rosbags(path)]
    assert got == [f'message {n:05d} ' + 'x' * (n % 50) for n in range(2000)]
    assert len(read_mcap(path)) == 2000


def test_split_by_duration(zros_node: Node, tmp_path: Path) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    publisher = talker.create_publisher(STRING, '/slow')
    recorder = Recorder(recording, tmp_path / 'bag', ['/slow'], split_duration=0.2)
    assert recorder.wait_for_topics(['/slow'])
    assert publisher.wait_for_subscribers()
    rate = talker.create_rate(40)
    for n in range(24):  # 0.6 s
        publisher.write(publisher.msg_type(data=str(n)))
        rate.sleep()
    assert wait_for(lambda: recorder.message_count == 24)
    recorder.close()
    info = bag_yaml(tmp_path / 'bag')
    assert len(info['files']) >= 3
    for entry in info['files']:
        assert entry['duration']['nanoseconds'] < 200_000_000
    assert [m.data for _, _, m in read_rosbags(tmp_path / 'bag')] == [str(n) for n in range(24)]


# --- errors ------------------------------------------------------------------------------------


def test_refusals(zros_node: Node, tmp_path: Path) -> None:
    node = zros_node('recording')
    with pytest.raises(RecorderError, match='nothing to record'):
        Recorder(node, tmp_path / 'a')
    with pytest.raises(RecorderError, match='regex'):
        Recorder(node, tmp_path / 'b', regex='([')
    (tmp_path / 'taken').mkdir()
    with pytest.raises(BagWriteError, match='already exists'):
        Recorder(node, tmp_path / 'taken', all=True)
    with pytest.raises(ValueError, match='unknown compression'):
        Recorder(node, tmp_path / 'c', all=True, compression='bz2')
    with pytest.raises(BagWriteError, match='must be positive'):
        Recorder(node, tmp_path / 'd', all=True, split_size=0)
    with pytest.raises(BagWriteError, match='must be positive'):
        Recorder(node, tmp_path / 'e', all=True, split_duration=-1)
    with pytest.raises(RecorderError, match='flush_interval'):
        Recorder(node, tmp_path / 'f', all=True, flush_interval=0)
    with pytest.raises(zros.NotInitializedError):
        Recorder(None, tmp_path / 'g', all=True)
    assert not any((tmp_path / name).exists() for name in 'abcdefg')


def test_a_failing_disk_stops_the_recording_with_an_error(
    zros_node: Node, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    talker, recording = zros_node('talker'), zros_node('recording')
    publisher = talker.create_publisher(STRING, '/doomed')
    recorder = Recorder(recording, tmp_path / 'bag', ['/doomed'])
    assert recorder.wait_for_topics(['/doomed'])
    assert publisher.wait_for_subscribers()

    def full(*args: object) -> None:
        raise OSError(28, 'No space left on device')

    monkeypatch.setattr(McapFile, 'write', full)
    publisher.write(publisher.msg_type(data='lost'))
    assert wait_for(lambda: recorder.error is not None)
    with pytest.raises(RecorderError, match='No space left on device'):
        recorder.close()
    recorder.close()  # a second close does nothing
