"""The bag writer without a network: rosbag2's metadata layout, QoS profiles, splits, errors."""

from __future__ import annotations

from pathlib import Path

import pytest

from zros.bag.errors import BagWriteError
from zros.bag.read.rosbag2_yaml import (
    FileEntry,
    bag_metadata,
    metadata_yaml,
    parse_qos_profiles,
    qos_profiles_text,
)
from zros.bag.write.bag_writer import BagTopic, BagWriter
from zros.bag.write.mcap_writer import McapFile
from zros.cdr import default_registry, encode, new_message
from zros.qos import Durability, History, QoS, Reliability

STRING = 'std_msgs/msg/String'

#: the layout of a metadata.yaml written by rosbag2 (yaml-cpp), for one topic and one file
EXPECTED = """\
rosbag2_bagfile_information:
  version: 8
  storage_identifier: mcap
  duration:
    nanoseconds: 70
  starting_time:
    nanoseconds_since_epoch: 1000
  message_count: 3
  topics_with_message_count:
    - topic_metadata:
        name: /chatter
        type: std_msgs/msg/String
        serialization_format: cdr
        offered_qos_profiles: "- history: 1\\n  depth: 10\\n  reliability: 1\\n  durability: 2\\n  \
deadline:\\n    sec: 9223372036\\n    nsec: 854775807\\n  lifespan:\\n    sec: 9223372036\\n    \
nsec: 854775807\\n  liveliness: 1\\n  liveliness_lease_duration:\\n    sec: 9223372036\\n    \
nsec: 854775807\\n  avoid_ros_namespace_conventions: false"
        type_description_hash: RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18
      message_count: 3
  compression_format: ""
  compression_mode: ""
  relative_file_paths:
    - talk_0.mcap
  files:
    - path: talk_0.mcap
      starting_time:
        nanoseconds_since_epoch: 1000
      duration:
        nanoseconds: 70
      message_count: 3
  custom_data: ~
  ros_distro: jazzy
"""


def test_metadata_has_rosbag2s_layout(tmp_path: Path) -> None:
    with BagWriter(tmp_path / 'talk', ros_distro='jazzy') as bag:
        index = bag.add_topic(
            BagTopic.from_registry(default_registry(), '/chatter', STRING, [QoS()])
        )
        for stamp in (1000, 1040, 1070):
            bag.write(index, stamp, encode(new_message(STRING, data='hi')))
    assert (tmp_path / 'talk' / 'metadata.yaml').read_text() == EXPECTED


def test_empty_bag_and_custom_data() -> None:
    text = metadata_yaml(
        bag_metadata([FileEntry('e_0.mcap', 0, 0, 0)], [], custom_data={'robot': 'r2: d2'})
    )
    assert '    nanoseconds_since_epoch: 9223372036854775807\n' in text
    assert '  topics_with_message_count: []\n' in text
    assert '  custom_data:\n    robot: "r2: d2"\n' in text
    from ruamel.yaml import YAML

    loaded = YAML(typ='safe').load(text)['rosbag2_bagfile_information']
    assert loaded['custom_data'] == {'robot': 'r2: d2'}
    assert loaded['ros_distro'] == ''


def test_qos_profiles_round_trip_and_the_other_versions() -> None:
    profiles = [
        QoS(1, durability=Durability.TRANSIENT_LOCAL),
        QoS(5, Reliability.BEST_EFFORT),
        QoS(100, history=History.KEEP_ALL),
    ]
    parsed = parse_qos_profiles(qos_profiles_text(profiles))
    assert parsed[:2] == profiles[:2]
    assert parsed[2].keep_all and parsed[2].depth == 10  # keep all has no depth
    version_9 = [
        {'history': 'keep_last', 'depth': 3, 'reliability': 'best_effort',
         'durability': 'transient_local'},
    ]  # fmt: skip
    assert parse_qos_profiles(version_9) == [
        QoS(3, Reliability.BEST_EFFORT, Durability.TRANSIENT_LOCAL)
    ]
    # what DDS reports (history unknown, depth 0) and system defaults become ROS defaults
    recorded = '- history: 3\n  depth: 0\n  reliability: 0\n  durability: 0'
    assert parse_qos_profiles(recorded) == [QoS(10)]
    assert parse_qos_profiles('') == parse_qos_profiles(None) == []
    with pytest.raises(ValueError, match='not valid YAML'):
        parse_qos_profiles('- history: [')
    with pytest.raises(ValueError, match='not a list'):
        parse_qos_profiles('history: 1')
    with pytest.raises(ValueError, match='must be a mapping'):
        parse_qos_profiles('- 1')


def test_writer_refusals(tmp_path: Path) -> None:
    bag = BagWriter(tmp_path / 'bag', compression=None)
    topic = BagTopic('/a', STRING, 'string data\n')
    bag.add_topic(topic)
    with pytest.raises(BagWriteError, match='already has a topic /a'):
        bag.add_topic(BagTopic('/a', STRING))
    bag.close()
    bag.close()
    with pytest.raises(BagWriteError, match='closed'):
        bag.write(0, 1, b'')
    with pytest.raises(BagWriteError, match='closed'):
        bag.add_topic(BagTopic('/b', STRING))
    blocker = tmp_path / 'file'
    blocker.write_text('')
    with pytest.raises(BagWriteError, match='cannot create'):
        BagWriter(blocker / 'bag')
    with pytest.raises(ValueError, match='chunk_size'):
        McapFile(tmp_path / 'x.mcap', chunk_size=0)


def test_unknown_types_get_no_definition(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    topic = BagTopic.from_registry(default_registry(), '/x', 'nope_msgs/msg/Nothing')
    assert (topic.definition, topic.type_hash, topic.encoding) == ('', '', '')
    assert 'recording /x without a definition' in caplog.text
    known = BagTopic.from_registry(default_registry(), '/s', STRING)
    assert (known.encoding, known.definition) == ('ros2msg', 'string data\n')


def test_files_are_chunked_by_size_and_flushed_on_demand(tmp_path: Path) -> None:
    file = McapFile(tmp_path / 'f.mcap', compression=None, chunk_size=1000)
    channel = file.add_channel(
        topic='/a', type_name=STRING, definition='string data\n', encoding='ros2msg',
        offered_qos_profiles='', type_hash='',
    )  # fmt: skip
    on_disk = file.size - file.pending
    pending = []
    for n in range(10):
        file.write(channel, n, n, b'\x00\x01\x00\x00' + bytes(96))
        pending.append(file.pending)
    assert 0 in pending and pending[0] > 0  # the chunk went out once it held 1000 bytes
    assert file.size - file.pending > on_disk + 1000
    file.write(channel, 10, 10, b'\x00\x01\x00\x00')
    assert file.pending > 0
    file.flush()
    assert file.pending == 0
    assert (file.stats.message_count, file.stats.start_ns, file.stats.end_ns) == (11, 0, 10)
    file.close(None)
    from mcap.reader import make_reader

    with (tmp_path / 'f.mcap').open('rb') as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert len(summary.chunk_indexes) == 2
    assert summary.statistics.message_count == 11


def test_topics_added_later_join_every_following_file(tmp_path: Path) -> None:
    text = encode(new_message(STRING, data='x' * 200))
    with BagWriter(tmp_path / 'bag', split_size=2000, chunk_size=500, compression=None) as bag:
        first = bag.add_topic(BagTopic('/first', STRING, 'string data\n'))
        for n in range(20):
            bag.write(first, n, text)
        second = bag.add_topic(BagTopic('/second', STRING, 'string data\n', qos=[QoS(1)]))
        for n in range(20, 40):
            bag.write(second, n, text)
        assert len(bag.files) > 2
    from mcap.reader import make_reader

    for file in sorted((tmp_path / 'bag').glob('*.mcap')):
        with file.open('rb') as stream:
            summary = make_reader(stream).get_summary()
        assert summary is not None
        topics = {channel.topic for channel in summary.channels.values()}
        assert '/first' in topics
    last = sorted((tmp_path / 'bag').glob('*.mcap'))[-1]
    with last.open('rb') as stream:
        summary = make_reader(stream).get_summary()
        metadata = list(make_reader(stream).iter_metadata())
    assert summary is not None
    assert {c.topic for c in summary.channels.values()} == {'/first', '/second'}
    assert metadata[0].name == 'rosbag2'
    assert 'message_count: 40' in metadata[0].metadata['serialized_metadata']
