"""rosbridge's JSON and CBOR shapes, through the gateway and a plain WebSocket: what a zros
publisher sends arrives as rosbridge_library's ``message_conversion`` writes it (NaN and
infinities null, byte arrays base64, 64-bit integers exact, times as ``{sec, nanosec}``), as
CBOR with typed arrays, as ``png``, in fragments; what a client publishes is checked as
rosbridge checks it (missing fields default, unknown fields and wrong types refused with a
status naming the field)."""

from __future__ import annotations

import base64
import json
import math
import struct
import zlib
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import zros
from tests.gateway.rosbridge.clients import RawClient
from zros.cdr import default_registry
from zros.gateway.rosbridge.frames import fragments, png_message, to_text, to_text_with

Make = Callable[..., Any]
TIMEOUT = 20.0
EDGES = 'zros_rosbridge_tests/msg/Edges'
EDGES_TEXT = """float64 f64
float32 f32
float64[3] fixed
float64[] seq
uint8[] data
uint8[4] data_fixed
uint8[<=4] data_bounded
char[] chars
byte b
byte[] bs
int64 big
uint64 ubig
bool flag
string text
builtin_interfaces/Time stamp
int32[] ints
uint16[] shorts
"""


@pytest.fixture(autouse=True)
def edges() -> None:
    if EDGES not in default_registry().names():
        zros.cdr.register_type(EDGES, EDGES_TEXT)


def edge_message() -> Any:
    return zros.Message(
        EDGES,
        f64=math.nan,
        f32=-math.inf,
        fixed=[1.5, math.inf, 2.0],
        seq=[math.nan, 0.25],
        data=b'\x00\xffhi',
        data_fixed=[1, 2, 3, 4],
        data_bounded=[7, 8],
        chars=[65, 66],
        b=200,
        bs=[1, 255],
        big=2**53 + 1,
        ubig=2**64 - 1,
        flag=True,
        text='ünï',
        stamp={'sec': 12, 'nanosec': 34},
        ints=[-1, 2],
        shorts=[1, 65535],
    )


def subscribe_and_publish(
    client: RawClient,
    zros_node: Make,
    message: Any,
    topic: str,
    op: str = 'publish',
    **options: Any,
) -> tuple[dict[str, Any], str | bytes]:
    """Subscribe ``client``, publish ``message`` from a zros node; the message of ``op`` that
    arrived, and its frame."""
    talker = zros_node('talker')
    pub = talker.create_publisher(message.__msgtype__, topic)
    client.send(op='subscribe', topic=topic, type=message.__msgtype__, **options)
    assert pub.wait_for_subscribers(TIMEOUT)
    start = client.mark()
    pub.write(message)
    found = client.wait(lambda m: m.get('op') == op, start=start)
    return found, client.frames[client.received.index(found)]


def test_json_shapes_are_rosbridge_s(rosbridge: Make, raw_client: Make, zros_node: Make) -> None:
    client = raw_client(rosbridge())
    found, frame = subscribe_and_publish(client, zros_node, edge_message(), '/edges')
    assert isinstance(frame, str) and 'NaN' not in frame and 'Infinity' not in frame
    assert str(2**53 + 1) in frame and str(2**64 - 1) in frame  # exact, as Python's json writes
    assert found['msg'] == {
        'f64': None,
        'f32': None,
        'fixed': [1.5, None, 2.0],
        'seq': [None, 0.25],
        'data': base64.b64encode(b'\x00\xffhi').decode(),
        'data_fixed': base64.b64encode(bytes([1, 2, 3, 4])).decode(),
        'data_bounded': [7, 8],  # bounded uint8 sequences stay lists in rosbridge
        'chars': base64.b64encode(b'AB').decode(),
        'b': 200,
        'bs': [1, 255],
        'big': 2**53 + 1,
        'ubig': 2**64 - 1,
        'flag': True,
        'text': 'ünï',
        'stamp': {'sec': 12, 'nanosec': 34},
        'ints': [-1, 2],
        'shorts': [1, 65535],
    }


def test_cbor_has_typed_arrays_and_raw_cbor_the_cdr_bytes(
    rosbridge: Make, raw_client: Make, zros_node: Make
) -> None:
    import cbor2

    client = raw_client(rosbridge())
    message = edge_message()
    found, frame = subscribe_and_publish(client, zros_node, message, '/edges', compression='cbor')
    assert isinstance(frame, bytes)
    values = found['msg']
    assert math.isnan(values['f64']) and values['f32'] == -math.inf  # CBOR keeps them
    assert values['data'] == b'\x00\xffhi' and values['chars'] == b'AB'
    assert values['seq'] == cbor2.CBORTag(86, np.array([math.nan, 0.25], '<f8').tobytes())
    assert values['fixed'] == cbor2.CBORTag(86, struct.pack('<3d', 1.5, math.inf, 2.0))
    assert values['ints'] == cbor2.CBORTag(78, struct.pack('<2i', -1, 2))
    assert values['shorts'] == cbor2.CBORTag(69, struct.pack('<2H', 1, 65535))
    assert values['ubig'] == 2**64 - 1 and values['stamp'] == {'sec': 12, 'nanosec': 34}

    raw, frame = subscribe_and_publish(
        client, zros_node, message, '/edges_raw', compression='cbor-raw'
    )
    assert isinstance(frame, bytes)
    assert raw['msg']['bytes'] == message.serialize()
    assert raw['msg']['secs'] > 1_600_000_000 and 0 <= raw['msg']['nsecs'] < 1_000_000_000


def png_text(data: str) -> str:
    """Decode a png message's data as roslibjs does (no PNG library: zlib and the rows)."""
    png = base64.b64decode(data)
    assert png.startswith(b'\x89PNG\r\n\x1a\n')
    width, height = struct.unpack('>II', png[16:24])
    body, position = b'', 8
    while position < len(png):
        (length,) = struct.unpack('>I', png[position : position + 4])
        kind = png[position + 4 : position + 8]
        if kind == b'IDAT':
            body += png[position + 8 : position + 8 + length]
        position += 12 + length
    rows = np.frombuffer(zlib.decompress(body), np.uint8).reshape(height, 1 + width * 3)
    assert not rows[:, 0].any()  # no filters
    return rows[:, 1:].tobytes().decode().rstrip('\n')


def test_png_and_fragments(rosbridge: Make, raw_client: Make, zros_node: Make) -> None:
    client = raw_client(rosbridge())
    message = zros.Message('std_msgs/msg/String', data='x' * 5000)
    found, _ = subscribe_and_publish(client, zros_node, message, '/big', 'png', compression='png')
    assert set(found) == {'op', 'data'}
    assert json.loads(png_text(found['data'])) == {
        'op': 'publish',
        'topic': '/big',
        'msg': {'data': 'x' * 5000},
    }


def test_long_base64_is_spliced_into_the_json_unchanged() -> None:
    from zros.cdr.registry import default_registry
    from zros.gateway.rosbridge.conversion import BLOB_SIZE, Values, blob_mark

    values = Values(default_registry(), lambda: (1, 2))
    pixels = np.arange(BLOB_SIZE * 3, dtype=np.uint32).astype(np.uint8)
    image = zros.Message('sensor_msgs/msg/Image', header={'frame_id': 'cam "1"'}, data=pixels)
    blobs: list[str] = []
    marked = values.to_json(image, blobs)
    assert marked['data'] == blob_mark(0) and len(blobs) == 1
    message = {'op': 'publish', 'topic': '/image', 'msg': marked}
    whole = {'op': 'publish', 'topic': '/image', 'msg': values.to_json(image)}
    assert to_text_with(message, blobs) == to_text(whole)  # what JSON's encoder would write
    assert base64.b64decode(json.loads(to_text_with(message, blobs))['msg']['data']) == bytes(
        pixels
    )
    several = {'a': blob_mark(0), 'b': [{'c': blob_mark(1)}], 'd': 'x'}
    assert json.loads(to_text_with(several, ['AAAA', 'BBBB'])) == {
        'a': 'AAAA',
        'b': [{'c': 'BBBB'}],
        'd': 'x',
    }
    with pytest.raises(ValueError, match='blob 0 is missing'):
        to_text_with({'a': 'no mark'}, ['AAAA'])


def test_fragments_join_into_the_message() -> None:
    text = json.dumps({'op': 'publish', 'topic': '/t', 'msg': {'data': 'y' * 250}})
    frames = fragments(text, 100)
    parts = [json.loads(f) for f in frames]
    count = math.ceil(len(text) / 100)
    assert [p['num'] for p in parts] == list(range(count)) and {p['total'] for p in parts} == {
        count
    }
    assert len({p['id'] for p in parts}) == 1 and parts[0]['id']  # roslibjs ignores id 0
    assert ''.join(p['data'] for p in parts) == text
    assert fragments(text, 10_000) == (text,)
    assert png_text(json.loads(png_message('ab'))['data']) == 'ab'  # 1 pixel wide at least


@pytest.mark.parametrize(('asked', 'size'), [(2000, 2000), (1, 1024)])
def test_a_subscription_s_fragment_size(
    rosbridge: Make, raw_client: Make, zros_node: Make, asked: int, size: int
) -> None:
    client = raw_client(rosbridge())
    client.send(op='set_level', level='warning')
    message = zros.Message('std_msgs/msg/String', data='f"\\' * 3000)  # escaped in fragments too
    first, _ = subscribe_and_publish(
        client, zros_node, message, '/fragmented', 'fragment', fragment_size=asked
    )
    total = first['total']
    client.wait(lambda m: m.get('op') == 'fragment' and m['num'] == total - 1)
    parts = sorted(client.of('fragment', id=first['id']), key=lambda m: m['num'])
    assert total == len(parts) > 1 and all(len(p['data']) <= size for p in parts)
    assert max(len(p['data']) for p in parts) == size  # below 1 KiB, 1 KiB is used
    assert json.loads(''.join(p['data'] for p in parts)) == {
        'op': 'publish',
        'topic': '/fragmented',
        'msg': {'data': 'f"\\' * 3000},
    }
    clamped = [m for m in client.of('status') if 'fragment_size' in m['msg']]
    assert clamped == ([] if asked == size else [client.status('fragment_size 1 is below 1024')])
    assert all(m['level'] == 'warning' for m in clamped)
