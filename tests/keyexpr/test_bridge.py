"""Golden values for the zenoh-bridge-ros2dds key scheme (shared/specs/bridge-protocol.md)."""

from __future__ import annotations

import pytest

from zros.keyexpr.bridge import (
    EntityToken,
    TokenQoS,
    action_key,
    admin_key,
    bridge_zid,
    dds_type_name,
    escape,
    ros_name,
    topic_key,
    unescape,
)
from zros.keyexpr.errors import InvalidNameError, TokenError
from zros.keyexpr.kinds import EntityKind
from zros.qos import LATCHED, ROSOUT, SENSOR_DATA, Durability, History, QoS, Reliability

ZID = '8f01344ee82211abd23a4b0ad673d0db'
STRING_HASH = 'RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18'


# §1: ROS name -> key, both bridge namespaces of the spec's examples
@pytest.mark.parametrize(
    ('name', 'namespace', 'key'),
    [
        ('/chatter', '/', 'chatter'),
        ('/turtle1/cmd_vel', '/', 'turtle1/cmd_vel'),
        ('/chatter', '/bot1', 'bot1/chatter'),
        ('/rosout', '/bot1', 'bot1/rosout'),
        ('/parameter_events', '/bot1', 'bot1/parameter_events'),
        ('/tf_static', '/bot1', 'bot1/tf_static'),
        ('/add_two_ints', '/', 'add_two_ints'),
        ('/zros_node/get_parameters', '/', 'zros_node/get_parameters'),
    ],
)
def test_topic_keys(name: str, namespace: str, key: str) -> None:
    assert topic_key(name, namespace) == key
    assert ros_name(key, namespace) == name


def test_reverse_mapping_reproduces_the_bridge() -> None:
    assert ros_name('other/x', '/bot1') == '/other/x'  # not under the namespace
    assert ros_name('bot10/x', '/bot1') == '0/x'  # the bridge's plain string prefix test (§1)
    with pytest.raises(InvalidNameError):
        topic_key('chatter')  # keys come from fully qualified names only
    with pytest.raises(InvalidNameError):
        topic_key('/chatter', 'bot1')


# §3.2: every row of the QoS chunk table
@pytest.mark.parametrize(
    ('qos', 'chunk'),
    [
        (TokenQoS(), ':::'),
        (TokenQoS(keyed=True), 'K:::'),
        (TokenQoS(reliability=Reliability.RELIABLE), ':1::'),
        (TokenQoS(durability=Durability.TRANSIENT_LOCAL), '::1:'),
        (TokenQoS(history=History.KEEP_LAST, depth=3), ':::0,3'),
        (TokenQoS.from_qos(QoS(10)), ':1:0:0,10'),
        (TokenQoS.from_qos(SENSOR_DATA), ':0:0:0,5'),
        (TokenQoS.from_qos(LATCHED), ':1:1:0,1'),
        (TokenQoS.from_qos(ROSOUT), ':1:1:0,1000'),
        (TokenQoS.from_qos(QoS(10), STRING_HASH), f':1:0:0,10:typehash={STRING_HASH};'),
    ],
)
def test_qos_chunks(qos: TokenQoS, chunk: str) -> None:
    assert qos.format() == chunk
    assert TokenQoS.parse(chunk) == qos


def test_qos_chunk_meaning() -> None:
    parsed = TokenQoS.parse(f':1:0:0,10:typehash={STRING_HASH};')
    assert parsed.type_hash == STRING_HASH
    assert parsed.to_qos() == QoS(10)
    # unset policies take the DDS defaults, which differ between writers and readers
    assert TokenQoS.parse(':::').to_qos(writer=True) == QoS(1, Reliability.RELIABLE)
    assert TokenQoS.parse(':::').to_qos(writer=False) == QoS(1, Reliability.BEST_EFFORT)
    assert TokenQoS.parse('::3:').to_qos().durability is Durability.TRANSIENT_LOCAL  # PERSISTENT
    assert TokenQoS.parse(':1:1:1,0').to_qos().keep_all


@pytest.mark.parametrize('chunk', ['', ':1', ':2::', '::7:', ':::x,1', ':::0', 'K:a::'])
def test_malformed_qos_chunks(chunk: str) -> None:
    with pytest.raises(TokenError):
        TokenQoS.parse(chunk)


# §3.1: the complete tokens of the spec
@pytest.mark.parametrize(
    ('token', 'text'),
    [
        (
            EntityToken(
                EntityKind.PUBLISHER,
                ZID,
                'chatter',
                'std_msgs/msg/String',
                TokenQoS.from_qos(QoS(10)),
            ),
            f'@/{ZID}/@ros2_lv/MP/chatter/std_msgs\u00a7msg\u00a7String/:1:0:0,10',
        ),
        (
            EntityToken(
                EntityKind.SUBSCRIBER,
                ZID,
                'bot1/turtle1/cmd_vel',
                'geometry_msgs/msg/Twist',
                TokenQoS.from_qos(QoS(10)),
            ),
            f'@/{ZID}/@ros2_lv/MS/bot1\u00a7turtle1\u00a7cmd_vel/geometry_msgs\u00a7msg\u00a7Twist/:1:0:0,10',
        ),
        (
            EntityToken(
                EntityKind.SERVICE_CLIENT,
                'f9cd6f8e79e88d43aa14144ed271a4ed',
                'set_task_service',
                'hare_robot_interfaces/srv/SetTask',
            ),
            '@/f9cd6f8e79e88d43aa14144ed271a4ed/@ros2_lv/SC/set_task_service/hare_robot_interfaces\u00a7srv\u00a7SetTask',
        ),
        (
            EntityToken(
                EntityKind.SERVICE_SERVER,
                ZID,
                'zros_node/get_parameters',
                'rcl_interfaces/srv/GetParameters',
            ),
            f'@/{ZID}/@ros2_lv/SS/zros_node\u00a7get_parameters/rcl_interfaces\u00a7srv\u00a7GetParameters',
        ),
        (
            EntityToken(
                EntityKind.ACTION_SERVER, ZID, 'fibonacci', 'example_interfaces/action/Fibonacci'
            ),
            f'@/{ZID}/@ros2_lv/AS/fibonacci/example_interfaces\u00a7action\u00a7Fibonacci',
        ),
    ],
)
def test_tokens(token: EntityToken, text: str) -> None:
    assert token.format() == text
    assert EntityToken.parse(text) == token


def test_bridge_tokens_and_admin_keys() -> None:
    assert EntityToken.parse(f'@/{ZID}/@ros2_lv') is None
    assert bridge_zid(f'@/{ZID}/@ros2_lv') == ZID
    assert bridge_zid(f'@/{ZID}/@ros2_lv/MP/a/b/:::') is None
    assert admin_key(ZID, 'version') == f'@/{ZID}/ros2/version'
    assert action_key('fibonacci', 'send_goal') == 'fibonacci/_action/send_goal'
    assert action_key('bot1/fibonacci', 'status') == 'bot1/fibonacci/_action/status'
    with pytest.raises(ValueError):
        action_key('fibonacci', 'result')
    assert dds_type_name('std_msgs/msg/String') == 'std_msgs::msg::dds_::String_'
    assert unescape(escape('a/b/c')) == 'a/b/c' and escape('a/b') == 'a\u00a7b'


# §3.3: zros never writes what would crash or confuse a bridge
@pytest.mark.parametrize(
    ('token', 'problem'),
    [
        (
            EntityToken(EntityKind.PUBLISHER, ZID, 'chatter', 'std_msgs/msg/String', None),
            'need a QoS',
        ),
        (
            EntityToken(EntityKind.PUBLISHER, ZID, 'chatter', 'std_msgs/srv/String', TokenQoS()),
            'pkg/msg/Name',
        ),
        (EntityToken(EntityKind.SERVICE_SERVER, ZID, 'x', 'std_msgs/msg/String'), 'pkg/srv/Name'),
        (
            EntityToken(EntityKind.PUBLISHER, ZID, '/chatter', 'std_msgs/msg/String', TokenQoS()),
            'not a valid Zenoh key',
        ),
        (
            EntityToken(EntityKind.PUBLISHER, ZID, 'a//b', 'std_msgs/msg/String', TokenQoS()),
            'not a valid Zenoh key',
        ),
        (
            EntityToken(EntityKind.PUBLISHER, ZID, 'a/*', 'std_msgs/msg/String', TokenQoS()),
            'never puts',
        ),
        (
            EntityToken(EntityKind.PUBLISHER, 'NOT-HEX', 'a', 'std_msgs/msg/String', TokenQoS()),
            'lowercase hex',
        ),
        (
            EntityToken(
                EntityKind.PUBLISHER,
                ZID,
                'a',
                'std_msgs/msg/String',
                TokenQoS(None, None, History.KEEP_LAST, 0),
            ),
            'outside 1..',
        ),
        (
            EntityToken(
                EntityKind.PUBLISHER, ZID, 'a', 'std_msgs/msg/String', TokenQoS(durability=3)
            ),
            'durability',
        ),  # type: ignore[arg-type]
    ],
)
def test_unsafe_tokens_are_refused(token: EntityToken, problem: str) -> None:
    with pytest.raises(TokenError, match=problem):
        token.format()


def test_type_hash_must_be_rihs01() -> None:
    with pytest.raises(TokenError, match='not a RIHS01'):
        TokenQoS.from_qos(QoS(), 'RIHS01_xyz')


@pytest.mark.parametrize(
    'text',
    [
        '@/z/@ros2_lv/XX/a/b',
        '@/z/@ros2_lv/MP/a/b',
        '@/z/@ros2_lv/SS/a',
        'chatter',
        '@/z/other/MP/a/b/:::',
    ],
)
def test_malformed_tokens(text: str) -> None:
    with pytest.raises(TokenError):
        EntityToken.parse(text)
