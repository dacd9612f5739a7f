"""The stand-in's own key, token and QoS code against the golden strings of the bridge spec,
then zros's token code judged by that parser.

No rclpy and no network: ``bridge_standin.protocol`` and ``zros.keyexpr.bridge`` are pure.
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.interop.bridge_standin import protocol as p
from zros.keyexpr.bridge import BridgeScheme
from zros.keyexpr.kinds import EntityKind
from zros.qos import Durability, History, QoS, Reliability

HERE = Path(__file__).resolve().parent
ZID = '8f01344ee82211abd23a4b0ad673d0db'
TYPEHASH = 'typehash=RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18;'


# --- §1 keys --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('ros_name', 'namespace', 'key'),
    [
        ('/chatter', '/', 'chatter'),
        ('/turtle1/cmd_vel', '/', 'turtle1/cmd_vel'),
        ('/chatter', '/bot1', 'bot1/chatter'),
        ('/rosout', '/bot1', 'bot1/rosout'),
        ('/tf_static', '/bot1', 'bot1/tf_static'),
        ('/zros_node/get_parameters', '/', 'zros_node/get_parameters'),
        ('/turtle1/cmd_vel', '/robots/a', 'robots/a/turtle1/cmd_vel'),
    ],
)
def test_ros_name_to_key(ros_name: str, namespace: str, key: str) -> None:
    assert p.ros_to_key(ros_name, namespace) == key
    assert p.key_to_ros(key, namespace) == ros_name


@pytest.mark.parametrize(
    ('key', 'namespace', 'ros_name'),
    [
        ('chatter', '/', '/chatter'),
        ('bot1/chatter', '/bot1', '/chatter'),
        # a key without the prefix keeps its whole name
        ('other/chatter', '/bot1', '/other/chatter'),
        # the bridge's plain string prefix test (spec §1, "bridge bug to respect")
        ('bot10/x', '/bot1', '0/x'),
    ],
)
def test_key_to_ros_name(key: str, namespace: str, ros_name: str) -> None:
    assert p.key_to_ros(key, namespace) == ros_name


def test_prefix_bug_gives_no_ros_name() -> None:
    assert not p.is_ros_name(p.key_to_ros('bot10/x', '/bot1'))
    assert p.is_ros_name('/chatter')
    assert p.is_ros_name('/turtle1/cmd_vel')
    assert not p.is_ros_name('chatter')
    assert not p.is_ros_name('/a//b')


@pytest.mark.parametrize('namespace', ['/', '/bot1', '/a/b', '/robot_1'])
def test_valid_namespaces(namespace: str) -> None:
    p.check_namespace(namespace)


@pytest.mark.parametrize('namespace', ['', 'bot1', '/bot-1', '/bot1/', '/b ot'])
def test_invalid_namespaces(namespace: str) -> None:
    with pytest.raises(ValueError, match='namespace'):
        p.check_namespace(namespace)


def test_dds_type_names() -> None:
    assert p.dds_type('std_msgs/msg/String') == 'std_msgs::msg::dds_::String_'
    assert p.dds_type('example_interfaces/srv/AddTwoInts') == (
        'example_interfaces::srv::dds_::AddTwoInts_'
    )


def test_escape() -> None:
    assert p.escape('std_msgs/msg/String') == 'std_msgs\u00a7msg\u00a7String'
    assert p.unescape('bot1\u00a7turtle1\u00a7cmd_vel') == 'bot1/turtle1/cmd_vel'
    assert '\u00a7'.encode() == b'\xc2\xa7'


# --- §3.2 QoS chunks --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ('chunk', 'qos'),
    [
        (':::', p.TokenQos()),
        ('K:::', p.TokenQos(keyed=True)),
        (':1::', p.TokenQos(reliability=p.RELIABLE)),
        ('::1:', p.TokenQos(durability=p.TRANSIENT_LOCAL)),
        (':::0,3', p.TokenQos(history=p.KEEP_LAST, depth=3)),
        (':1:0:0,10', p.TokenQos(False, p.RELIABLE, p.VOLATILE, p.KEEP_LAST, 10)),
        (':0:0:0,5', p.TokenQos(False, p.BEST_EFFORT, p.VOLATILE, p.KEEP_LAST, 5)),
        (':1:1:0,1', p.TokenQos(False, p.RELIABLE, p.TRANSIENT_LOCAL, p.KEEP_LAST, 1)),
        (':1:1:0,1000', p.TokenQos(False, p.RELIABLE, p.TRANSIENT_LOCAL, p.KEEP_LAST, 1000)),
        (
            f':1:0:0,10:{TYPEHASH}',
            p.TokenQos(False, p.RELIABLE, p.VOLATILE, p.KEEP_LAST, 10, TYPEHASH),
        ),
        (':1:0:1,1000', p.TokenQos(False, p.RELIABLE, p.VOLATILE, p.KEEP_ALL, 1000)),
        # TRANSIENT and PERSISTENT are legal (the bridge maps them to CycloneDDS as they are)
        ('::2:', p.TokenQos(durability=p.TRANSIENT)),
        ('::3:', p.TokenQos(durability=p.PERSISTENT)),
        # keep-all ignores its depth
        (':::1,0', p.TokenQos(history=p.KEEP_ALL, depth=0)),
    ],
)
def test_qos_chunks(chunk: str, qos: p.TokenQos) -> None:
    assert p.TokenQos.parse(chunk) == qos
    assert qos.to_chunk() == chunk


@pytest.mark.parametrize(
    ('chunk', 'reason'),
    [
        ('', 'fields'),
        (':1:0', 'fields'),
        (':2::', 'reliability 2 is out of range'),
        (':-1::', 'not a number'),
        ('::4:', 'durability 4 is out of range'),
        (':::2,1', 'history kind 2 is out of range'),
        (':::0,0', 'keep-last needs depth >= 1'),
        (':::0,-5', 'keep-last needs depth >= 1'),
        (':::0,x', 'not a number'),
        (':::0', 'KIND,DEPTH'),
        (':::0,2147483648', 'not an i32'),
        (':a::', 'not a number'),
    ],
)
def test_malformed_qos_chunks(chunk: str, reason: str) -> None:
    with pytest.raises(p.TokenError, match=reason):
        p.TokenQos.parse(chunk)


# --- §3.1 tokens ------------------------------------------------------------------------------

GOLDEN_TOKENS = [
    (
        f'@/{ZID}/@ros2_lv/MP/chatter/std_msgs\u00a7msg\u00a7String/:1:0:0,10',
        p.Token(
            ZID,
            p.Kind.MP,
            'chatter',
            'std_msgs/msg/String',
            p.TokenQos(False, 1, 0, 0, 10),
        ),
    ),
    (
        f'@/{ZID}/@ros2_lv/MS/bot1\u00a7turtle1\u00a7cmd_vel/geometry_msgs\u00a7msg\u00a7Twist/:1:0:0,10',
        p.Token(
            ZID,
            p.Kind.MS,
            'bot1/turtle1/cmd_vel',
            'geometry_msgs/msg/Twist',
            p.TokenQos(False, 1, 0, 0, 10),
        ),
    ),
    (
        '@/f9cd6f8e79e88d43aa14144ed271a4ed/@ros2_lv/SC/set_task_service/hare_robot_interfaces\u00a7srv\u00a7SetTask',
        p.Token(
            'f9cd6f8e79e88d43aa14144ed271a4ed',
            p.Kind.SC,
            'set_task_service',
            'hare_robot_interfaces/srv/SetTask',
        ),
    ),
    (
        f'@/{ZID}/@ros2_lv/SS/zros_node\u00a7get_parameters/rcl_interfaces\u00a7srv\u00a7GetParameters',
        p.Token(ZID, p.Kind.SS, 'zros_node/get_parameters', 'rcl_interfaces/srv/GetParameters'),
    ),
    (
        f'@/{ZID}/@ros2_lv/AS/fibonacci/example_interfaces\u00a7action\u00a7Fibonacci',
        p.Token(ZID, p.Kind.AS, 'fibonacci', 'example_interfaces/action/Fibonacci'),
    ),
]


@pytest.mark.parametrize(
    ('key', 'token'), GOLDEN_TOKENS, ids=[t.kind.value for _, t in GOLDEN_TOKENS]
)
def test_golden_tokens(key: str, token: p.Token) -> None:
    assert p.parse_token(key) == token
    assert token.to_key() == key


def test_plugin_token() -> None:
    assert p.plugin_token(ZID) == f'@/{ZID}/@ros2_lv'
    assert p.parse_token(f'@/{ZID}/@ros2_lv') == ZID


def test_remote_route_key() -> None:
    token = GOLDEN_TOKENS[1][1]
    assert token.remote_route == f'{ZID}:bot1/turtle1/cmd_vel'


T = 'std_msgs\u00a7msg\u00a7String'

MALFORMED_TOKENS = [
    (f'@/{ZID}/@ros2_lv/', 'shorter than'),
    (f'@/{ZID}/@ros2_lv/M', 'shorter than'),
    (f'@/{ZID}/@ros2_lv/\u00a7P/x/{T}/:::', 'non-ASCII'),
    (f'@/{ZID}/@ros2_lv/XX/chatter/{T}/:::', 'unknown entity kind'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/{T}', 'chunks'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/{T}/:::/extra', 'chunks'),
    (f'@/{ZID}/@ros2_lv/SS/add/example_interfaces\u00a7srv\u00a7AddTwoInts/:::', 'chunks'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/{T}/:7::', 'out of range'),
    (f'@/{ZID}/@ros2_lv/MS/chatter/{T}/::9:', 'out of range'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/{T}/:::3,1', 'out of range'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/{T}/:1:0:0,0', 'depth >= 1'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/std_msgs\u00a7String/:::', 'is not pkg/msg/Name'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/std_msgs::msg::dds_::String_/:::', 'is not pkg/msg/Name'),
    (f'@/{ZID}/@ros2_lv/MP/chatter/std_msgs\u00a7srv\u00a7String/:::', 'is not pkg/msg/Name'),
    (f'@/{ZID}/@ros2_lv/SS/add/std_msgs\u00a7msg\u00a7String', 'is not pkg/srv/Name'),
    (f'@/{ZID}/@ros2_lv/MP/\u00a7chatter/{T}/:::', 'not a valid Zenoh key'),
    (f'@/{ZID}/@ros2_lv/MP/a\u00a7\u00a7b/{T}/:::', 'not a valid Zenoh key'),
    (f'@/{ZID}/@ros2_lv/MP/a\u00a7*/{T}/:::', 'wildcard'),
    (f'@/{ZID}/@ros2_lv2', 'not a zenoh-bridge-ros2dds token'),
    (f'@/{ZID}/other/MP/chatter/{T}/:::', 'not a zenoh-bridge-ros2dds token'),
]


@pytest.mark.parametrize(('key', 'reason'), MALFORMED_TOKENS)
def test_malformed_tokens(key: str, reason: str) -> None:
    with pytest.raises(p.TokenError, match=reason):
        p.parse_token(key)


# --- §8 admin space ---------------------------------------------------------------------------


def test_admin_replies() -> None:
    assert p.admin_prefix(ZID) == f'@/{ZID}/ros2'
    assert p.version_json('1.10.0') == '"v1.10.0"'
    config = json.loads(p.config_json('/bot1', 'zenoh_bridge_ros2dds', 3))
    assert config['namespace'] == '/bot1'
    assert config['nodename'] == 'zenoh_bridge_ros2dds'
    assert config['domain'] == 3


# --- independence from zros -------------------------------------------------------------------


@pytest.mark.parametrize(
    'path',
    [*sorted((HERE / 'bridge_standin').glob('*.py')), HERE / 'ros_worker.py'],
    ids=lambda path: path.name,
)
def test_standin_does_not_import_zros(path: Path) -> None:
    tree = ast.parse(path.read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported.update(alias.name.split('.')[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module.split('.')[0])
    assert 'zros' not in imported


# --- zros's tokens pass this parser (the stand-in is the judge, zros the subject) --------------

_CHUNK = st.from_regex(r'[A-Za-z][A-Za-z0-9]{0,6}(_[A-Za-z0-9]{1,4})?', fullmatch=True)
_NAMES = st.lists(_CHUNK, min_size=1, max_size=4).map(lambda chunks: '/' + '/'.join(chunks))
_NAMESPACES = st.one_of(
    st.just('/'), st.lists(_CHUNK, min_size=1, max_size=2).map(lambda c: '/' + '/'.join(c))
)
_TYPES = {
    'msg': ['std_msgs/msg/String', 'sensor_msgs/msg/PointCloud2', 'tf2_msgs/msg/TFMessage'],
    'srv': ['std_srvs/srv/Trigger', 'rcl_interfaces/srv/GetParameters'],
    'action': ['example_interfaces/action/Fibonacci'],
}


@settings(max_examples=300, deadline=None)
@given(data=st.data())
def test_zros_tokens_parse_as_the_bridge_expects(data: st.DataObject) -> None:
    """Whatever QoS, namespace and name zros is given, its token is one the bridge accepts."""
    kind = data.draw(st.sampled_from(list(EntityKind)), label='kind')
    namespace = data.draw(_NAMESPACES, label='bridge namespace')
    name = data.draw(_NAMES, label='ROS name')
    zid = data.draw(st.from_regex(r'[0-9a-f]{1,32}', fullmatch=True), label='zid')
    depth = data.draw(st.integers(1, 2**31 - 1), label='depth')
    reliability = data.draw(st.sampled_from(list(Reliability)), label='reliability')
    durability = data.draw(st.sampled_from(list(Durability)), label='durability')
    history = data.draw(st.sampled_from(list(History)), label='history')
    type_hash = data.draw(
        st.one_of(st.none(), st.from_regex(r'RIHS01_[0-9a-f]{64}', fullmatch=True)), label='hash'
    )
    interface = {'M': 'msg', 'S': 'srv', 'A': 'action'}[kind.value[0]]
    type_name = data.draw(st.sampled_from(_TYPES[interface]), label='type')
    qos = QoS(depth, reliability, durability, history)
    scheme = BridgeScheme(namespace, send_type_hash=type_hash is not None)
    key = scheme.token(kind, zid, name, type_name, qos=qos, type_hash=type_hash)

    token = p.parse_token(key)
    assert isinstance(token, p.Token)
    assert (token.zid, token.kind.value, token.type_name) == (zid, kind.value, type_name)
    assert token.key == p.ros_to_key(name, namespace)
    assert p.key_to_ros(token.key, namespace) == name
    assert token.to_key() == key
    if not kind.has_qos:
        assert token.qos is None
        return
    assert token.qos == p.TokenQos(
        False,
        int(reliability),
        int(durability),
        int(history),
        depth,
        None if type_hash is None else f'typehash={type_hash};',
    )
