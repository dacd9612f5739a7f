"""Golden values for the rmw_zenoh scheme: every example of shared/specs/rmw-zenoh-protocol.md."""

from __future__ import annotations

import os

import pytest

from zros.cdr import default_registry
from zros.cdr.hashing import type_hash
from zros.keyexpr.attachment import Attachment
from zros.keyexpr.bridge import BridgeScheme
from zros.keyexpr.errors import AttachmentError, InvalidNameError, TokenError
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.rmw_zenoh import (
    ALL_TOKENS,
    HASH_NOT_SUPPORTED,
    INFINITE,
    EndpointToken,
    IdCounter,
    NodeToken,
    RmwQoS,
    RmwZenohScheme,
    data_key,
    dds_type_name,
    demangle,
    gid,
    mangle,
    parse_token,
    ros_type_name,
    strip_slashes,
    token_selector,
)
from zros.keyexpr.xxh3 import xxh3_128, xxh3_128_digest
from zros.qos import LATCHED, ROSOUT, SENSOR_DATA, Durability, History, QoS, Reliability

H = 'RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18'  # std_msgs String
A = 'RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a'  # AddTwoInts
IMAGE = 'RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47'
STRING = 'std_msgs::msg::dds_::String_'
ADD = 'example_interfaces::srv::dds_::AddTwoInts_'


# --- §1: data keys ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('domain', 'name', 'type_name', 'hash_', 'key'),
    [
        (0, '/chatter', 'std_msgs/msg/String', H, f'0/chatter/{STRING}/{H}'),
        (0, '/robot1/chatter', 'std_msgs/msg/String', H, f'0/robot1/chatter/{STRING}/{H}'),
        (0, '/add_two_ints', 'example_interfaces/srv/AddTwoInts', A, f'0/add_two_ints/{ADD}/{A}'),
        (2, '/add_two_ints', 'example_interfaces/srv/AddTwoInts', A, f'2/add_two_ints/{ADD}/{A}'),
        (
            0,
            '/fibonacci/_action/send_goal',
            'example_interfaces/action/Fibonacci_SendGoal',
            'RIHS01_d1a57fb2a4afe8c21e34fb10db206f16ce6729b28531141472df92277c55b557',
            '0/fibonacci/_action/send_goal/example_interfaces::action::dds_::Fibonacci_SendGoal_/'
            'RIHS01_d1a57fb2a4afe8c21e34fb10db206f16ce6729b28531141472df92277c55b557',
        ),
        (
            0,
            '/chatter',
            'std_msgs/msg/String',
            HASH_NOT_SUPPORTED,
            f'0/chatter/{STRING}/TypeHashNotSupported',
        ),
    ],
)
def test_data_keys(domain: int, name: str, type_name: str, hash_: str, key: str) -> None:
    assert data_key(domain, name, type_name, hash_) == key


def test_scheme_keys_use_the_computed_hashes() -> None:
    registry = default_registry()
    scheme = RmwZenohScheme(0)
    hash_ = type_hash(registry, 'std_msgs/msg/String')
    assert scheme.data_key('/chatter', 'std_msgs/msg/String', hash_) == f'0/chatter/{STRING}/{H}'
    assert scheme.key('/robot1/chatter') == '0/robot1/chatter'
    humble = RmwZenohScheme(0, humble=True)
    assert humble.data_key('/chatter', 'std_msgs/msg/String', None).endswith(
        '/TypeHashNotSupported'
    )
    with pytest.raises(TokenError, match='need the type hash'):
        scheme.data_key('/chatter', 'std_msgs/msg/String', None)


def test_bridge_scheme_has_the_same_interface() -> None:
    bridge = BridgeScheme('/bot1')
    assert bridge.data_key('/chatter', 'std_msgs/msg/String', H) == 'bot1/chatter'
    assert bridge.node_token('abcd', 0, '/', 'talker') is None
    assert not bridge.attachments and bridge.action_tokens
    rmw = RmwZenohScheme()
    assert rmw.attachments and not rmw.action_tokens and rmw.namespace == '/'
    assert repr(rmw) == '<RmwZenohScheme domain=0>'
    assert repr(RmwZenohScheme(3, humble=True)) == '<RmwZenohScheme domain=3 humble>'


@pytest.mark.parametrize(
    ('ros', 'dds'),
    [
        ('std_msgs/msg/String', 'std_msgs::msg::dds_::String_'),
        ('example_interfaces/srv/AddTwoInts', 'example_interfaces::srv::dds_::AddTwoInts_'),
        (
            'example_interfaces/action/Fibonacci_SendGoal',
            'example_interfaces::action::dds_::Fibonacci_SendGoal_',
        ),
        ('action_msgs/srv/CancelGoal', 'action_msgs::srv::dds_::CancelGoal_'),
        ('action_msgs/msg/GoalStatusArray', 'action_msgs::msg::dds_::GoalStatusArray_'),
    ],
)
def test_dds_type_names(ros: str, dds: str) -> None:
    assert dds_type_name(ros) == dds
    assert ros_type_name(dds) == ros


def test_key_errors() -> None:
    assert ros_type_name('not_a_dds_name') == 'not_a_dds_name'
    with pytest.raises(TokenError):
        dds_type_name('std_msgs/String')
    with pytest.raises(TokenError, match='RIHS01'):
        data_key(0, '/chatter', 'std_msgs/msg/String', 'RIHS01_short')
    with pytest.raises(TokenError, match='domain'):
        data_key(-1, '/chatter', 'std_msgs/msg/String', H)
    with pytest.raises(TokenError, match='domain'):
        RmwZenohScheme(True)  # type: ignore[arg-type]
    with pytest.raises(InvalidNameError):
        data_key(0, 'chatter', 'std_msgs/msg/String', H)
    assert strip_slashes('/a/b/') == 'a/b' and strip_slashes('a') == 'a'


# --- §2: tokens and GIDs ------------------------------------------------------------------------

EXAMPLES = [
    (
        '@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener',
        '5bd72f4daf53c0bb00c7394e7fc19547',
    ),
    (
        f'@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/{STRING}/{H}/'
        '::,10:,:,:,,',
        'f15f21d2fafc22891bb0db868309bfcb',
    ),
    (
        f'@ros2_lv/0/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/{STRING}/{H}/'
        '::,7:,:,:,,',
        'eb85fa883b7846dc448a4501890ad062',
    ),
    (
        '@ros2_lv/0/f9980ee0495eaafb3e38f0d19e2eae12/0/10/SS/%/%/add_two_ints_server/'
        f'%add_two_ints/{ADD}/{A}/::,10:,:,:,,',
        'd47771a4e2405c092088d4552a3b7b13',
    ),
    (
        '@ros2_lv/0/e1dc8d1b45ae8717fce78689cc655685/0/10/SC/%/%/add_two_ints_client/'
        f'%add_two_ints/{ADD}/{A}/::,10:,:,:,,',
        '26970b3b2b7cf4e3c6219b0549875e8c',
    ),
]


@pytest.mark.parametrize(('token', 'gid_hex'), EXAMPLES)
def test_design_md_tokens_and_gids(token: str, gid_hex: str) -> None:
    assert gid(token).hex() == gid_hex
    parsed = parse_token(token)
    assert parsed.format() == token  # parse and format are inverse on every example


def test_tokens_built_from_parts() -> None:
    scheme = RmwZenohScheme(0)
    talker = scheme.node('8b20917502ee955ac4476e0266340d5c', 0, '/', 'talker')
    assert talker.format() == '@ros2_lv/0/8b20917502ee955ac4476e0266340d5c/0/0/NN/%/%/talker'
    token = scheme.token(
        EntityKind.PUBLISHER, talker.zid, '/chatter', 'std_msgs/msg/String',
        qos=QoS(7), type_hash=H, node=talker, entity_id=10,
    )  # fmt: skip
    assert token == EXAMPLES[2][0]
    server = scheme.node('f9980ee0495eaafb3e38f0d19e2eae12', 0, '/', 'add_two_ints_server')
    token = scheme.token(
        EntityKind.SERVICE_SERVER, server.zid, '/add_two_ints',
        'example_interfaces/srv/AddTwoInts', type_hash=A, node=server, entity_id=10,
    )  # fmt: skip
    assert token == EXAMPLES[3][0]


def test_namespaced_node_example() -> None:
    zid = '1234abcd'
    scheme = RmwZenohScheme()
    cam = scheme.node(zid, 3, '/robot1', 'cam')
    assert scheme.node_token(zid, 3, '/robot1', 'cam') == f'@ros2_lv/0/{zid}/3/3/NN/%/%robot1/cam'
    token = scheme.token(
        EntityKind.PUBLISHER, zid, '/robot1/image', 'sensor_msgs/msg/Image',
        qos=SENSOR_DATA, type_hash=IMAGE, node=cam, entity_id=4,
    )  # fmt: skip
    expected = (
        f'@ros2_lv/0/{zid}/3/4/MP/%/%robot1/cam/%robot1%image/sensor_msgs::msg::dds_::Image_/'
        f'{IMAGE}/2::,5:,:,:,,'
    )
    assert token == expected
    parsed = parse_token(token)
    assert isinstance(parsed, EndpointToken)
    assert parsed.node == cam and parsed.node.fully_qualified_name == '/robot1/cam'
    assert parsed.topic == '/robot1/image' and parsed.type_name == 'sensor_msgs/msg/Image'
    assert parsed.qos.to_qos() == SENSOR_DATA
    deeper = parse_token(NodeToken(0, zid, 1, '/a/b', 'n').format())
    assert isinstance(deeper, NodeToken) and deeper.namespace == '/a/b'
    assert mangle('/a/b') == '%a%b' and demangle('%a%b') == '/a/b'


def test_token_selectors() -> None:
    assert token_selector(0) == '@ros2_lv/0/**'
    assert ALL_TOKENS == '@ros2_lv/**'


def test_parsing_ignores_extra_chunks() -> None:
    token = EXAMPLES[2][0] + '/backends:cuda:x%3Ay'
    parsed = parse_token(token)
    assert isinstance(parsed, EndpointToken) and parsed.entity_id == 10


@pytest.mark.parametrize(
    ('token', 'error'),
    [
        ('@ros2_lv/0/abc/0/0/NN/%/%', 'not an rmw_zenoh token'),  # 8 parts
        ('@/abc/@ros2_lv/MP/chatter/std_msgs§msg§String/:::', 'not an rmw_zenoh token'),
        ('@ros2_lv/0/abc/0/0/NN/%//listener', 'empty chunk'),
        ('@ros2_lv/x/abc/0/0/NN/%/%/listener', 'not a number'),
        ('@ros2_lv/0/abc/0/0/XX/%/%/listener', 'unknown entity kind'),
        ('@ros2_lv/0/abc/0/1/AS/%/%/listener/%f/t/h/q', 'unknown entity kind'),
        ('@ros2_lv/0/abc/0/1/MP/%/%/listener/%chatter/t/h', 'an endpoint needs 13'),
        (f'@ros2_lv/0/abc/0/1/MP/%/%/l/%chatter/{STRING}/{H}/::,10:,:,:,', 'needs 3'),
        (f'@ros2_lv/0/abc/0/1/MP/%/%/l/%chatter/{STRING}/{H}/::,x:,:,:,,', 'invalid number'),
    ],
)
def test_malformed_tokens(token: str, error: str) -> None:
    with pytest.raises(TokenError, match=error):
        parse_token(token)


def test_refused_tokens() -> None:
    scheme = RmwZenohScheme()
    node = scheme.node('abcd', 0, '/', 'talker')
    with pytest.raises(TokenError, match='node and entity id'):
        scheme.token(EntityKind.PUBLISHER, 'abcd', '/chatter', 'std_msgs/msg/String', type_hash=H)
    with pytest.raises(TokenError, match='belongs to session'):
        scheme.token(
            EntityKind.PUBLISHER, 'ef01', '/chatter', 'std_msgs/msg/String',
            type_hash=H, node=node, entity_id=1,
        )  # fmt: skip
    with pytest.raises(TokenError, match='no ACTION_SERVER tokens'):
        EndpointToken(node, 1, EntityKind.ACTION_SERVER, '/f', 'a::action::dds_::F_', A).format()
    with pytest.raises(TokenError, match='entity id'):
        EndpointToken(node, -1, EntityKind.PUBLISHER, '/f', STRING, H).format()
    with pytest.raises(TokenError, match='zid'):
        NodeToken(0, 'XYZ', 0, '/', 'n').format()
    with pytest.raises(TokenError, match='node id'):
        NodeToken(0, 'ab', -1, '/', 'n').format()
    with pytest.raises(TokenError, match='enclave'):
        NodeToken(0, 'ab', 0, '/', 'n', enclave='').format()
    with pytest.raises(TokenError, match='type'):
        EndpointToken(node, 1, EntityKind.PUBLISHER, '/f', 'bad*type', H).format()
    with pytest.raises(InvalidNameError):
        NodeToken(0, 'ab', 0, '/', 'bad name').format()


def test_a_secure_enclave_is_mangled() -> None:
    token = NodeToken(0, 'ab', 0, '/', 'n', enclave='/secure/bot').format()
    assert token == '@ros2_lv/0/ab/0/0/NN/%secure%bot/%/n'
    node = parse_token(token)
    assert isinstance(node, NodeToken) and node.enclave == '/secure/bot'


def test_ids_come_from_one_counter() -> None:
    counter = IdCounter()
    assert [counter() for _ in range(3)] == [0, 1, 2]


# --- XXH3-128 -----------------------------------------------------------------------------------


def test_xxh3_known_digests() -> None:
    # the XXH3-128 of the empty input (seed 0), as published with xxHash
    assert xxh3_128_digest(b'').hex() == '99aa06d3014798d86001c324468d497f'
    low, high = xxh3_128(b'')
    assert (high << 64 | low) == 0x99AA06D3014798D86001C324468D497F


def test_xxh3_matches_xxhash_on_every_path() -> None:
    xxhash = pytest.importorskip('xxhash', reason='xxhash (a pyzeros dependency) cross-checks')
    sizes = [*range(0, 260), 511, 512, 1023, 1024, 1025, 2048, 2049, 4100]
    for size in sizes:
        data = os.urandom(size)
        assert xxh3_128_digest(data) == xxhash.xxh3_128_digest(data), size


# --- §3: the QoS string -------------------------------------------------------------------------

SECOND = (1, 0)


@pytest.mark.parametrize(
    ('profile', 'chunk'),
    [
        (RmwQoS(depth=10), '::,10:,:,:,,'),
        (RmwQoS(depth=7), '::,7:,:,:,,'),
        (RmwQoS(reliability=2, depth=5), '2::,5:,:,:,,'),
        (RmwQoS(durability=1, depth=1), ':1:,1:,:,:,,'),
        (RmwQoS(durability=1, depth=1000, lifespan=(10, 0)), ':1:,1000:,:10,0:,,'),
        (RmwQoS(depth=1000), '::,1000:,:,:,,'),
        (RmwQoS(history=2, depth=0), '::2,:,:,:,,'),
        (RmwQoS(depth=10, deadline=SECOND), '::,10:1,0:,:,,'),
        (RmwQoS(depth=10, liveliness=1, lease=(2, 500000000)), '::,10:,:,:,2,500000000'),
    ],
)
def test_qos_vectors(profile: RmwQoS, chunk: str) -> None:
    assert profile.format() == chunk
    assert RmwQoS.parse(chunk) == profile.adapted()


def test_zros_profiles() -> None:
    assert RmwQoS.from_qos(QoS(10)).format() == '::,10:,:,:,,'
    assert RmwQoS.from_qos(SENSOR_DATA).format() == '2::,5:,:,:,,'
    assert RmwQoS.from_qos(LATCHED).format() == ':1:,1:,:,:,,'
    assert RmwQoS.from_qos(ROSOUT).format() == ':1:,1000:,:,:,,'
    keep_all = QoS(1000, history=History.KEEP_ALL)
    assert RmwQoS.parse(RmwQoS.from_qos(keep_all).format()).to_qos() == keep_all


def test_legacy_baseline_and_lenient_parsing() -> None:
    legacy = RmwQoS.parse(':2:,10:,:,:,,')  # old releases wrote VOLATILE explicitly
    assert legacy.to_qos() == QoS(10)
    assert legacy.format() == '::,10:,:,:,,'
    assert RmwQoS.parse('::,:,:,:,,:extra') == RmwQoS()
    assert RmwQoS.parse('3::,0:,:,:,,').to_qos() == QoS(42, Reliability.RELIABLE)


def test_adapted_profile() -> None:
    system_default = RmwQoS(0, 0, 0, 0, (0, 0), (0, 0), 0, (0, 0))
    assert system_default.adapted() == RmwQoS()
    assert system_default.format() == '::,:,:,:,,'
    best_available = RmwQoS(reliability=4, durability=4, liveliness=5)
    assert best_available.adapted() == RmwQoS()
    assert RmwQoS().deadline == INFINITE
    for unknown in ({'reliability': 3}, {'durability': 3}, {'history': 3}, {'liveliness': 4}):
        with pytest.raises(TokenError, match='UNKNOWN'):
            RmwQoS(**unknown).format()  # type: ignore[arg-type]
    with pytest.raises(TokenError, match='negative'):
        RmwQoS(depth=10, deadline=(-1, 0)).format()
    assert RmwQoS(durability=1).to_qos().durability is Durability.TRANSIENT_LOCAL


@pytest.mark.parametrize(
    ('chunk', 'error'),
    [
        ('::,10:,:', 'expected 6'),
        (':::,:,:,,', 'needs 2'),
        ('::,10:1:,:,,', 'needs 2'),
        ('-1::,10:,:,:,,', 'invalid number'),
        ('::,1e3:,:,:,,', 'invalid number'),
        ('::,\u0661:,:,:,,', 'invalid number'),  # a non-ASCII digit
    ],
)
def test_malformed_qos(chunk: str, error: str) -> None:
    with pytest.raises(TokenError, match=error):
        RmwQoS.parse(chunk)


# --- §4: attachments ----------------------------------------------------------------------------

TALKER_GID = bytes.fromhex('eb85fa883b7846dc448a4501890ad062')
STAMP = 1700000000123456789


def test_attachment_example() -> None:
    attachment = Attachment(1, STAMP, TALKER_GID)
    data = attachment.encode()
    assert data.hex() == ('010000000000000015cd853dfe9c971710eb85fa883b7846dc448a4501890ad062')
    assert len(data) == 33
    assert Attachment.decode(data) == attachment
    assert Attachment.decode(bytearray(data)) == attachment


def test_attachment_matches_zenoh_ext_serializer() -> None:
    from zenoh import ZBytes
    from zenoh.ext import Int64, z_deserialize, z_serialize

    data = z_serialize((Int64(1), Int64(STAMP), TALKER_GID))
    assert data.to_bytes() == Attachment(1, STAMP, TALKER_GID).encode()
    seq, stamp, gid_ = z_deserialize(
        tuple[Int64, Int64, bytes], ZBytes(Attachment(5, 6, TALKER_GID).encode())
    )
    assert (seq, stamp, bytes(gid_)) == (5, 6, TALKER_GID)


def test_legacy_attachment_example() -> None:
    legacy = bytes.fromhex(
        '0f73657175656e63655f6e756d626572' '0100000000000000'
        '10736f757263655f74696d657374616d70' '15cd853dfe9c9717'
        '0a736f757263655f676964' '10' 'eb85fa883b7846dc448a4501890ad062'
    )  # fmt: skip
    assert len(legacy) == 77
    attachment = Attachment(1, STAMP, TALKER_GID)
    assert attachment.encode_legacy() == legacy
    assert Attachment.decode(legacy) == attachment
    # the two forms are mutually unintelligible: the first byte tells them apart
    assert legacy[0] == 0x0F and attachment.encode()[0] != 0x0F


def test_service_example_attachment() -> None:
    client_gid = gid(EXAMPLES[4][0])
    assert client_gid.hex() == '26970b3b2b7cf4e3c6219b0549875e8c'
    data = Attachment(1, STAMP, client_gid).encode()
    assert data[:8].hex() == '0100000000000000'
    assert data[16:].hex() == '10' + '26970b3b2b7cf4e3c6219b0549875e8c'


@pytest.mark.parametrize(
    ('data', 'error'),
    [
        (b'', 'not 0'),
        (b'\x01' * 32, 'not 32'),
        (bytes(16) + b'\x0f' + bytes(16), 'length byte is 15'),
        (b'\x0fsequence_numbeX' + bytes(61), 'lacks the field sequence_number'),
        (
            Attachment(1, 2, TALKER_GID).encode_legacy()[:-17] + b'\x0f' + bytes(16),
            'length byte is 15',
        ),
    ],
)
def test_bad_attachments(data: bytes, error: str) -> None:
    with pytest.raises(AttachmentError, match=error):
        Attachment.decode(data)


def test_attachment_values_are_checked() -> None:
    with pytest.raises(AttachmentError, match='16 bytes'):
        Attachment(1, 2, b'short')
    with pytest.raises(AttachmentError, match='int64'):
        Attachment(2**63, 2, TALKER_GID)
    assert Attachment.decode(Attachment(-1, -2, TALKER_GID).encode()).sequence_number == -1


# --- §6.4 and §8.3: hashes of the action parts and the published test vectors -------------------


@pytest.mark.parametrize(
    ('type_name', 'expected'),
    [
        ('std_msgs/msg/String', H),
        ('sensor_msgs/msg/Image', IMAGE),
        (
            'sensor_msgs/msg/PointCloud2',
            'RIHS01_9198cabf7da3796ae6fe19c4cb3bdd3525492988c70522628af5daa124bae2b5',
        ),
        ('example_interfaces/srv/AddTwoInts', A),
        (
            'example_interfaces/srv/AddTwoInts_Event',
            'RIHS01_32c1d140259c71e5c355115942bcb31df98b4330e4d906b1b75ccb1c9b3ce6c8',
        ),
        (
            'example_interfaces/action/Fibonacci_SendGoal',
            'RIHS01_d1a57fb2a4afe8c21e34fb10db206f16ce6729b28531141472df92277c55b557',
        ),
        (
            'example_interfaces/action/Fibonacci_GetResult',
            'RIHS01_1b0de0d5d29dc955d92f546706568428632771db13ec84c15ec1c1a59f424a57',
        ),
        (
            'action_msgs/srv/CancelGoal',
            'RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a',
        ),
        (
            'example_interfaces/action/Fibonacci_FeedbackMessage',
            'RIHS01_c1de71afd52e49a89c53d8262366884185bc0a02f78ce051c4e46b0a7fe59bb2',
        ),
        (
            'action_msgs/msg/GoalStatusArray',
            'RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e',
        ),
    ],
)
def test_spec_hashes(type_name: str, expected: str) -> None:
    assert type_hash(default_registry(), type_name) == expected
