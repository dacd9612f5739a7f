"""``zros foxglove --bag``: recordings served to a real Foxglove client with playback control."""

from __future__ import annotations

import base64
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

import zros
from tests.gateway.foxglove.client import FoxgloveClient
from zros.bag.write.bag_writer import BagTopic, BagWriter
from zros.cdr import default_registry
from zros.cdr.message import decode
from zros.cdr.render import render_bundle
from zros.gateway.common.errors import GatewayError
from zros.qos import LATCHED, QoS

pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

from zros.gateway.foxglove.server import serve

Make = Callable[..., Any]
START = 1_000 * 10**9
STEP = 100_000_000  # 0.1 s
PLAY, PAUSE = 0, 1
PLAYING, PAUSED, ENDED = 0, 1, 3


@pytest.fixture
def recording(tmp_path: Path) -> tuple[Path, list[bytes], bytes]:
    """A bag: a latched /tf_static at the start, then 20 /chatter messages 0.1 s apart."""
    registry = default_registry()
    static = zros.Message(
        'tf2_msgs/msg/TFMessage',
        transforms=[{'header': {'frame_id': 'map'}, 'child_frame_id': 'odom'}],
    ).serialize()
    chatter = [
        zros.Message('std_msgs/msg/String', data=f'hello {i}').serialize() for i in range(20)
    ]
    with BagWriter(tmp_path / 'bag') as bag:
        tf = bag.add_topic(
            BagTopic.from_registry(registry, '/tf_static', 'tf2_msgs/msg/TFMessage', [LATCHED])
        )
        talk = bag.add_topic(
            BagTopic.from_registry(registry, '/chatter', 'std_msgs/msg/String', [QoS()])
        )
        bag.write(tf, START, static)
        for i, data in enumerate(chatter):
            bag.write(talk, START + i * STEP, data)
    return tmp_path / 'bag', chatter, static


@pytest.fixture
def bag_server() -> Any:
    made: list[Any] = []

    def make(path: Path, **options: Any) -> Any:
        server = serve(bag=path, port=0, **options)
        made.append(server)
        return server

    yield make
    for server in made:
        server.close()


def _request(
    client: FoxgloveClient, command: int, speed: float, seek: int | None
) -> dict[str, Any]:
    request = f'r{client.mark()}'
    start = client.mark()
    client.send('playback', command=command, speed=speed, seek=seek, requestId=request)
    return client.wait(
        lambda e: e['ev'] == 'playbackState' and e['requestId'] == request, start=start
    )


def test_a_bag_plays_pauses_and_seeks(
    recording: tuple[Path, list[bytes], bytes], bag_server: Make, foxglove_client: Make
) -> None:
    path, chatter, static = recording
    server = bag_server(path)
    client: FoxgloveClient = foxglove_client(server.url)
    info = client.server_info()
    assert {'playbackControl', 'time'} <= set(info['capabilities'])
    talk = client.subscribe('/chatter')
    tf = client.subscribe('/tf_static')
    assert client.channels()['/chatter']['schema'] == 'string data\n'  # the bag's own definition

    state = _request(client, PLAY, 20.0, None)
    assert state['status'] == PLAYING
    assert client.wait_messages(talk, 20) == chatter
    assert client.wait_messages(tf, 1) == [static]
    stamps = [int(e['timestamp']) for e in client.of('message') if e['subscriptionId'] == talk]
    assert stamps == [START + i * STEP for i in range(20)]  # recorded times, not receive times
    client.wait(lambda e: e['ev'] == 'playbackState' and e['status'] == ENDED)
    client.wait(lambda e: e['ev'] == 'time' and int(e['timestamp']) >= START + 19 * STEP)

    start = client.mark()
    seek = START + 15 * STEP - 1  # just before message 15
    state = _request(client, PLAY, 20.0, seek)
    assert state['status'] == PLAYING and state['didSeek']
    client.wait(lambda e: client.count(talk) >= 25, start=start)
    assert client.messages(talk)[20:] == chatter[15:]
    assert client.messages(tf) == [static, static]  # the latched message again after the seek

    paused = _request(client, PAUSE, 1.0, START)
    assert paused['status'] == PAUSED and paused['didSeek']
    assert int(paused['currentTime']) == START
    assert server.clock.paused


def test_a_rosbag2_recording_keeps_its_schemas_and_bytes(
    testdata: Path, bag_server: Make, foxglove_client: Make
) -> None:
    from zros.bag.read.source import open_source

    path = testdata / 'ros2' / 'talker_mcap'
    with open_source(path) as source:
        definitions = {c.topic: c.definition for c in source.connections}
        recorded = [bytes(m.data) for m in source.messages() if m.connection.topic == '/topic']
    server = bag_server(path, topics=['/topic'])
    client: FoxgloveClient = foxglove_client(server.url)
    assert client.channel('/topic')['schema'] == definitions['/topic']
    assert set(client.channels()) == {'/topic'}
    subscription = client.subscribe('/topic')
    _request(client, PLAY, 100.0, None)
    received = client.wait_messages(subscription, len(recorded))
    assert received == recorded and len(recorded) == 10
    assert base64.b64encode(received[0]).decode() == client.of('message')[0]['data']


SQLITE_AND_ROS1 = {
    # talker_sqlite3 embeds a wrong Log (``uint8 level`` only): the registry's fits the data
    'sqlite': ('ros2/talker_sqlite3', '/rosout', 'rcl_interfaces/msg/Log', True),
    # a ROS 1 bag's definitions, as converted to ROS 2, fit
    'ros1': (
        'ros1/fake_sensors_sample.bag',
        '/my_temperature',
        'sensor_msgs/msg/Temperature',
        False,
    ),
}


@pytest.mark.parametrize('case', SQLITE_AND_ROS1.values(), ids=SQLITE_AND_ROS1)
def test_sqlite_and_ros1_bags_play_with_schemas_that_fit_their_data(
    testdata: Path, bag_server: Make, foxglove_client: Make, case: tuple[str, str, str, bool]
) -> None:
    from zros.bag.read.source import open_source

    recording, topic, type_name, from_registry = case
    path = testdata / recording
    with open_source(path) as source:
        (connection,) = [c for c in source.connections if c.topic == topic]
        recorded = [bytes(m.data) for m in source.messages([connection])]
    server = bag_server(path)
    client: FoxgloveClient = foxglove_client(server.url)
    channel = client.channel(topic)
    assert channel['schemaName'] == type_name
    registry_text = render_bundle(default_registry(), type_name)
    assert channel['schema'] == (registry_text if from_registry else connection.definition)
    cls = default_registry().get_class(type_name)
    subscription = client.subscribe(topic)
    _request(client, PLAY, 100.0, None)
    received = client.wait_messages(subscription, len(recorded))
    assert received == recorded
    assert [type(decode(cls, data, strict=True)) for data in received] == [cls] * len(recorded)


def test_a_bag_without_selected_topics_is_refused(
    recording: tuple[Path, list[bytes], bytes], bag_server: Make
) -> None:
    with pytest.raises(GatewayError, match='no topic of'):
        bag_server(recording[0], topics=['/nothing'])


def test_latched_messages_beyond_the_bound_are_not_kept(
    recording: tuple[Path, list[bytes], bytes],
    bag_server: Make,
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    from zros.gateway.foxglove import bag_server as foxglove_bag

    monkeypatch.setattr(foxglove_bag, 'LATCHED_BYTES', 8)
    bag_server(recording[0])
    assert 'latched topics hold more than 8 bytes: not all kept' in caplog.text


def test_a_seek_sends_the_newest_latched_message_of_a_long_recording(
    tmp_path: Path,
    bag_server: Make,
    foxglove_client: Make,
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    from zros.gateway.foxglove import bag_server as foxglove_bag

    registry = default_registry()
    statics = [
        zros.Message(
            'tf2_msgs/msg/TFMessage',
            transforms=[{'header': {'frame_id': 'map'}, 'child_frame_id': f'odom{i}'}],
        ).serialize()
        for i in range(50)
    ]
    with BagWriter(tmp_path / 'bag') as bag:
        tf = bag.add_topic(
            BagTopic.from_registry(registry, '/tf_static', 'tf2_msgs/msg/TFMessage', [LATCHED])
        )
        talk = bag.add_topic(
            BagTopic.from_registry(registry, '/chatter', 'std_msgs/msg/String', [QoS()])
        )
        for i, data in enumerate(statics):
            bag.write(tf, START + i * STEP, data)
        end = START + len(statics) * STEP
        bag.write(talk, end, zros.Message('std_msgs/msg/String', data='end').serialize())
    # the bound holds a few messages: the depth (1) keeps one, so reading on costs nothing
    monkeypatch.setattr(foxglove_bag, 'LATCHED_BYTES', 4 * len(statics[0]))
    server = bag_server(tmp_path / 'bag')
    client: FoxgloveClient = foxglove_client(server.url)
    subscription = client.subscribe('/tf_static')
    _request(client, PAUSE, 1.0, end)
    # every latched message read counted against the bound, kept or not: the read stopped at
    # the 5th and a seek sent that one
    assert client.wait_messages(subscription, 1) == [statics[-1]]
    assert 'not all kept' not in caplog.text
