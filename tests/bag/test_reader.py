"""Typed reading: every recorded message equals what rosbags decodes, and bad data is named."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

import zros
from tests.bag.makebags import make_db3, make_schema_mcap
from tests.bag.reference import RECORDINGS, assert_same, rosbags_messages
from zros.bag import Bag, BagError, UndecodedMessage, bag_read
from zros.cdr import encode, new_message


@pytest.mark.parametrize('name', RECORDINGS)
def test_every_message_equals_rosbags(testdata: Path, name: str) -> None:
    path = testdata / name
    expected = rosbags_messages(path)
    with Bag(path) as bag:
        got = list(bag.messages())
        assert bag.message_count == len(expected)
        assert sum(info.count for info in bag.topics.values()) == len(expected)
    assert [(t, s) for t, s, _ in got] == [(e[0], e[2]) for e in expected] or sorted(
        (t, s) for t, s, _ in got
    ) == sorted((e[0], e[2]) for e in expected)
    # messages with equal timestamps may be ordered differently: pair them per topic
    by_topic: dict[str, list[tuple[int, object]]] = {}
    for topic, stamp, message in got:
        by_topic.setdefault(topic, []).append((stamp, message))
    theirs: dict[str, list[tuple[int, str, object]]] = {}
    for topic, type_name, stamp, message in expected:
        theirs.setdefault(topic, []).append((stamp, type_name, message))
    assert by_topic.keys() == theirs.keys()
    for topic, mine in by_topic.items():
        for (stamp, message), (stamp2, type_name, other) in zip(mine, theirs[topic], strict=True):
            assert stamp == stamp2
            assert message.__msgtype__ == type_name
            assert_same(message, other, f'{name} {topic} @{stamp}')


def test_bag_read_has_the_four_rosr_columns(testdata: Path) -> None:
    path = testdata / 'ros2' / 'talker_mcap'
    read = zros.bag_read(path, topics=['/topic'])
    assert len(read) == 10
    assert read.topic == ['/topic'] * 10
    assert read['data_type'] == ['std_msgs/msg/String'] * 10
    assert read.time_stamp == sorted(read.time_stamp)
    assert [m.data for m in read.message] == [f'Hello, world! {i}' for i in range(10)]
    rows = list(read)
    assert rows[0] == ('/topic', 'std_msgs/msg/String', read.time_stamp[0], read.message[0])
    with pytest.raises(KeyError, match='the columns are'):
        read['stamp']
    everything = bag_read(path)
    assert set(everything.topic) == {'/topic', '/rosout'}
    assert len(everything) == 20


def test_topics_and_time_window(testdata: Path) -> None:
    with Bag(testdata / 'ros2' / 'talker_mcap') as bag:
        assert bag.topics['/rosout'].type_name == 'rcl_interfaces/msg/Log'
        assert bag.topics['/rosout'].count == 10
        stamps = [s for _, s, _ in bag.messages('/rosout')]
        window = [s for _, s, _ in bag.messages('/rosout', start=stamps[3], end=stamps[6])]
        assert window == stamps[3:6]
        assert [s for _, s, _ in bag.messages('/rosout', start=zros.Time(stamps[8]))] == stamps[8:]
        # the times of bag.columns are numpy int64: they bound a read as they are
        numpy_window = bag.messages('/rosout', start=np.int64(stamps[3]), end=np.uint64(stamps[6]))
        assert [s for _, s, _ in numpy_window] == stamps[3:6]
        for wrong in (1.5, True, np.float64(stamps[3])):
            with pytest.raises(TypeError, match='nanoseconds'):
                list(bag.messages(start=wrong))
        with pytest.raises(BagError, match=r'no topic /nothing in the recording; it has: /topic'):
            list(bag.messages(['/nothing']))
        assert bag.message_class('/topic').__msgtype__ == 'std_msgs/msg/String'


def test_messages_are_decoded_as_the_iteration_reaches_them(testdata: Path) -> None:
    with Bag(testdata / 'ros2' / 'wbag_split_mcap') as bag:
        decoded = []
        original = bag.types.decode

        def counting(raw: object) -> object:
            decoded.append(raw)
            return original(raw)  # type: ignore[arg-type]

        bag.types.decode = counting  # type: ignore[method-assign]
        stream = bag.messages()
        next(stream)
        next(stream)
        assert len(decoded) == 2


def test_wrong_embedded_definition_falls_back_to_the_registry(
    testdata: Path, caplog: pytest.LogCaptureFixture
) -> None:
    with (
        caplog.at_level(logging.WARNING, 'zros.bag'),
        Bag(testdata / 'ros2' / 'talker_sqlite3') as bag,
    ):
        logs = [m for _, _, m in bag.messages('/rosout')]
    assert [m.msg for m in logs][:1] and all(m.name == 'minimal_publisher' for m in logs)
    warnings = [
        r.getMessage() for r in caplog.records if 'does not match its data' in r.getMessage()
    ]
    assert len(warnings) == 1
    assert 'talker_sqlite3' in warnings[0] and '/rosout' in warnings[0]


def test_definition_mismatch_without_fallback_skips_or_raises_strict(tmp_path: Path) -> None:
    # a type no registry knows, whose embedded definition is too short for its data
    data = b'\x00\x01\x00\x00' + bytes(range(12))
    path = make_db3(
        tmp_path / 'mismatch.db3',
        [('/thing', 'zros_test/msg/Thing')],
        [(0, 5, data)],
        {'zros_test/msg/Thing': 'uint8 level'},
    )
    with Bag(path) as bag:
        assert list(bag.messages()) == []  # skipped, counted
        [skipped] = bag.skipped
    assert (skipped.file, skipped.row, skipped.topic, skipped.lost) == (path, 1, '/thing', 1)
    with Bag(path, strict=True) as bag, pytest.raises(BagError) as info:
        list(bag.messages())
    text = str(info.value)
    assert str(path) in text and 'row 1' in text
    assert 'cannot decode the message of /thing at 5 as zros_test/msg/Thing' in text
    assert 'bytes left after the end of the message' in text


SECRET = 'secret_pkg/msg/Secret'
SECRET_TEXT = 'int32 code\nfloat64 level\n'


def secret_bag(path: Path) -> tuple[Path, list[bytes]]:
    """A bag whose /secret topic has a type defined nowhere (no schema, unknown to zros),
    beside /chatter and /point; returns it and the /secret messages' bytes."""
    from zros.bag import BagTopic, BagWriter
    from zros.cdr import TypeRegistry, default_registry

    registry = TypeRegistry(paths=[])
    registry.register_text(SECRET, SECRET_TEXT)
    secret = registry.get_class(SECRET)
    known = default_registry()
    secrets = [encode(secret(code=n, level=n / 4)) for n in range(3)]
    with BagWriter(path) as writer:
        chatter = writer.add_topic(BagTopic.from_registry(known, '/chatter', 'std_msgs/msg/String'))
        point = writer.add_topic(BagTopic.from_registry(known, '/point', 'geometry_msgs/msg/Point'))
        hidden = writer.add_topic(BagTopic('/secret', SECRET))  # recorded without a definition
        for n in range(3):
            writer.write(
                chatter, 10 + 3 * n, encode(new_message('std_msgs/msg/String', data=f'c{n}'))
            )
            writer.write(point, 11 + 3 * n, encode(new_message('geometry_msgs/msg/Point', x=n)))
            writer.write(hidden, 12 + 3 * n, secrets[n])
    return path, secrets


def test_a_type_defined_nowhere_reads_as_bytes_and_the_rest_decodes(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:

    path, secrets = secret_bag(tmp_path / 'secret')
    with caplog.at_level(logging.WARNING, 'zros.bag'):
        read = bag_read(path)
    assert read.topic == ['/chatter', '/point', '/secret'] * 3
    assert read.data_type == ['std_msgs/msg/String', 'geometry_msgs/msg/Point', SECRET] * 3
    assert [m.data for m in read.message[0::3]] == ['c0', 'c1', 'c2']
    assert [m.x for m in read.message[1::3]] == [0.0, 1.0, 2.0]
    raw = read.message[2::3]
    assert all(isinstance(m, UndecodedMessage) and m.__msgtype__ == SECRET for m in raw)
    assert [m.data for m in raw] == secrets
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1, warnings  # one warning, not one per message
    assert SECRET in warnings[0] and 'UndecodedMessage' in warnings[0]
    assert f'ZROS_INTERFACE_PATH=<a folder holding {SECRET}.msg>' in warnings[0]
    assert f"zros.cdr.register_type('{SECRET}'" in warnings[0]
    with Bag(path) as bag:
        assert bag.columns('/point', ['x'])['x'].tolist() == [0.0, 1.0, 2.0]
        with pytest.raises(BagError, match=f'topic /secret has type {SECRET}, which has no def'):
            bag.columns('/secret')
        with pytest.raises(BagError, match='ZROS_INTERFACE_PATH'):
            bag.message_class('/secret')
    # the message object behaves: equal by content, copied, pickled; no fields to list
    import copy
    import pickle

    assert raw[0] == copy.copy(raw[0]) == pickle.loads(pickle.dumps(raw[0]))
    assert (
        raw[0] != raw[1] and repr(raw[0]) == f'UndecodedMessage({SECRET}, {len(secrets[0])} bytes)'
    )
    with pytest.raises(TypeError, match='no definition'):
        raw[0].to_dict()


def test_the_warning_says_how_to_decode_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from zros.cdr import TypeRegistry

    path, _ = secret_bag(tmp_path / 'secret')
    folder = tmp_path / 'msgs'
    (folder / 'secret_pkg' / 'msg').mkdir(parents=True)
    (folder / 'secret_pkg' / 'msg' / 'Secret.msg').write_text(SECRET_TEXT)
    monkeypatch.setenv('ZROS_INTERFACE_PATH', str(folder))  # the line the warning gives
    with Bag(path, registry=TypeRegistry()) as bag:
        secrets = [m for t, _, m in bag.messages('/secret')]
        assert [(m.code, m.level) for m in secrets] == [(0, 0.0), (1, 0.25), (2, 0.5)]
        assert bag.columns('/secret', ['code'])['code'].tolist() == [0, 1, 2]


def test_data_that_fits_no_definition(tmp_path: Path) -> None:
    # a known type with a truncated message: the embedded and registry definitions both fail
    good = encode(new_message('std_msgs/msg/String', data='hello'))
    path = make_db3(
        tmp_path / 'short.db3',
        [('/chatter', 'std_msgs/msg/String')],
        [(0, 1, good), (0, 2, good[:-4])],
        {'std_msgs/msg/String': 'string data'},
    )
    with Bag(path) as bag:
        assert [m.data for _, _, m in bag.messages()] == ['hello']
        assert [(s.row, s.lost) for s in bag.skipped] == [(2, 1)]
    with Bag(path, strict=True) as bag:
        stream = bag.messages()
        assert next(stream)[2].data == 'hello'
        with pytest.raises(BagError, match=r'row 2 .*cannot decode the message of /chatter at 2'):
            next(stream)


def test_recording_without_definitions_uses_the_registry(tmp_path: Path) -> None:
    twist = new_message('geometry_msgs/msg/Twist', linear={'x': 1.5})
    path = make_db3(
        tmp_path / 'plain.db3', [('/cmd_vel', 'geometry_msgs/msg/Twist')], [(0, 7, encode(twist))]
    )
    with Bag(path) as bag:
        assert bag.connections[0].definition_format == ''
        ((topic, stamp, message),) = list(bag.messages())
    assert (topic, stamp) == ('/cmd_vel', 7)
    assert message == twist


def test_idl_definitions_are_parsed(tmp_path: Path) -> None:
    from mcap.writer import Writer

    idl = (
        'module zros_test {\n  module msg {\n    struct Point {\n      double x;\n'
        '      int32 count;\n    };\n  };\n};\n'
    )
    path = tmp_path / 'idl.mcap'
    data = b'\x00\x01\x00\x00' + (2.5).hex().encode()[:0] + b'\x00' * 0
    import struct

    data = b'\x00\x01\x00\x00' + struct.pack('<di', 2.5, 7)
    with path.open('wb') as stream:
        writer = Writer(stream)
        writer.start(profile='ros2', library='test')
        schema = writer.register_schema('zros_test/msg/Point', 'ros2idl', idl.encode())
        channel = writer.register_channel('/point', 'cdr', schema)
        writer.add_message(channel, log_time=3, data=data, publish_time=3)
        writer.finish()
    with Bag(path) as bag:
        assert bag.connections[0].definition_format == 'ros2idl'
        ((_, _, point),) = list(bag.messages())
    assert (point.x, point.count) == (2.5, 7)


def test_service_events_decode(testdata: Path) -> None:
    path = testdata / 'ros2' / 'services_and_topics' / 'topics_and_services.mcap'
    with Bag(path) as bag:
        events = [m for _, _, m in bag.messages('/add_two_ints/_service_event')]
    assert len(events) == 6
    requests = [e.request[0] for e in events if len(e.request)]
    assert requests and all(hasattr(r, 'a') and hasattr(r, 'b') for r in requests)
    responses = [e.response[0] for e in events if len(e.response)]
    assert responses and all(hasattr(r, 'sum') for r in responses)


def test_bag_error_is_a_zros_error(tmp_path: Path) -> None:
    with pytest.raises(zros.ZrosError):
        Bag(tmp_path / 'missing')


@pytest.mark.parametrize('compression', ['BZ2', 'LZ4', None])
def test_ros1_bags_with_compressed_chunks(tmp_path: Path, compression: str | None) -> None:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    T = store.types
    path = tmp_path / 'sensors.bag'
    writer = Writer(path)
    if compression:
        writer.set_compression(Writer.CompressionFormat[compression])
    with writer:
        imu = writer.add_connection('/imu', 'sensor_msgs/msg/Imu', typestore=store, latching=1)
        text = writer.add_connection('/text', 'std_msgs/msg/String', typestore=store)
        for index in range(40):
            header = T['std_msgs/msg/Header'](
                seq=index, stamp=T['builtin_interfaces/msg/Time'](index, 5), frame_id='imu'
            )
            vector = T['geometry_msgs/msg/Vector3'](index, -1.0, 0.5)
            message = T['sensor_msgs/msg/Imu'](
                header,
                T['geometry_msgs/msg/Quaternion'](0.0, 0.0, 0.0, 1.0),
                np.arange(9, dtype=np.float64) * index,
                vector,
                np.zeros(9),
                vector,
                np.ones(9),
            )
            stamp = 10**9 + index * 10**6
            writer.write(imu, stamp, store.serialize_ros1(message, 'sensor_msgs/msg/Imu'))
            words = T['std_msgs/msg/String'](f'word {index}')
            writer.write(text, stamp + 1, store.serialize_ros1(words, 'std_msgs/msg/String'))
    expected = rosbags_messages(path)
    with Bag(path) as bag:
        got = list(bag.messages())
        # a latched ROS 1 topic is offered transient local (durability 1), as rosbags-convert does
        assert 'durability: 1' in bag.topics['/imu'].connections[0].qos
        assert bag.topics['/text'].connections[0].qos == ''
        columns = bag.columns('/imu', ['angular_velocity.x', 'orientation_covariance'])
    assert len(got) == len(expected) == 80
    for (topic, stamp, message), (topic2, _, stamp2, other) in zip(got, expected, strict=True):
        assert (topic, stamp) == (topic2, stamp2)
        assert_same(message, other, topic)
    assert columns['angular_velocity.x'].tolist() == list(range(40))
    assert columns['orientation_covariance'][3].tolist() == [3.0 * i for i in range(9)]


def test_a_bag_counts_its_topics_and_messages_in_words(tmp_path: Path) -> None:
    from tests.bag.makebags import make_points_mcap
    from zros.bag.read.source import open_source

    path = make_points_mcap(tmp_path / 'one.mcap', 1)
    with Bag(path) as bag:
        assert repr(bag) == f'<Bag {bag.path}: 1 topic, 1 message>'
    with open_source(path) as source:
        assert repr(source).endswith(': 1 connection, 1 message>')


def test_an_empty_schema_with_longer_messages_is_an_unknown_type(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # a recorder that did not know the type wrote an empty ros2msg schema: its messages are not
    # empty ones (4-byte header and at most 4 more), so they come back undecoded, not skipped
    path = tmp_path / 'unknown.mcap'
    payloads = [b'\x00\x01\x00\x00' + bytes(range(n, n + 7)) for n in range(3)]
    schemas = [
        ('/mystery', 'their_pkg/msg/Mystery', 'ros2msg', b''),
        ('/empty', 'their_pkg/msg/Nothing', 'ros2msg', b''),
    ]
    rows = [(0, stamp, payload) for stamp, payload in enumerate(payloads)]
    make_schema_mcap(path, schemas, [*rows, (1, 9, b'\x00\x01\x00\x00\x00')])
    with caplog.at_level('WARNING', logger='zros'), Bag(path) as bag:
        mystery = [m for _, _, m in bag.messages(['/mystery'])]
        ((_, _, nothing),) = list(bag.messages(['/empty']))
    assert [m.data for m in mystery] == payloads
    assert all(isinstance(m, UndecodedMessage) for m in mystery)
    assert not isinstance(nothing, UndecodedMessage)  # an empty message decodes as one
    warnings = [r.getMessage() for r in caplog.records]
    assert len(warnings) == 1, warnings
    assert 'their_pkg/msg/Mystery (topic /mystery) has an empty definition' in warnings[0]


def test_a_folder_of_one_file_without_metadata_opens_quietly(
    testdata: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    import shutil

    mcap = testdata / 'ros2' / 'services_and_topics' / 'topics_and_services.mcap'
    one = tmp_path / 'one'
    one.mkdir()
    shutil.copy(mcap, one / mcap.name)
    two = tmp_path / 'two'
    two.mkdir()
    shutil.copy(mcap, two / 'a.mcap')
    shutil.copy(mcap, two / 'b.mcap')
    with caplog.at_level('WARNING', logger='zros'):
        with Bag(one) as bag:
            assert bag.topics
        assert not caplog.records  # once a warning on every open
        with Bag(two):
            pass
    assert [r.getMessage() for r in caplog.records] == [
        f'{two}: it has no metadata.yaml: read file by file'
    ]
