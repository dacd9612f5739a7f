"""ROS 2 name rules, expansion and remapping (rcl/rmw semantics)."""

from __future__ import annotations

import pytest

from zros.keyexpr.errors import InvalidNameError
from zros.keyexpr.names import (
    Remapping,
    expand,
    parse_ros_args,
    validate_full_name,
    validate_name,
    validate_namespace,
    validate_node_name,
)


@pytest.mark.parametrize(
    ('name', 'node', 'namespace', 'full'),
    [
        ('/chatter', 'talker', '/', '/chatter'),
        ('chatter', 'talker', '/', '/chatter'),
        ('chatter', 'talker', '/robot', '/robot/chatter'),
        ('a/b', 'talker', '/robot/arm', '/robot/arm/a/b'),
        ('~', 'talker', '/robot', '/robot/talker'),
        ('~/status', 'talker', '/', '/talker/status'),
        ('~/status', 'talker', '/robot', '/robot/talker/status'),
        ('/abs/olute', 'talker', '/robot', '/abs/olute'),
    ],
)
def test_expand(name: str, node: str, namespace: str, full: str) -> None:
    assert expand(name, node, namespace) == full


@pytest.mark.parametrize(
    ('name', 'index', 'rule'),
    [
        ('', 0, 'must not be empty'),
        ('7up', 0, 'must not start with a digit'),
        ('foo/', 3, 'must not end with "/"'),
        ('/', 0, 'must not end with "/"'),
        ('foo bar', 3, 'only letters, digits'),
        ('foo-bar', 3, 'only letters, digits'),
        ('a/~b', 2, '"~" is only allowed first'),
        ('~foo', 1, '"~" must be followed by "/"'),
        ('{node}/x', 0, 'substitutions'),
        ('caf\u00e9', 3, 'only letters, digits'),
    ],
)
def test_invalid_names_say_which_rule(name: str, index: int, rule: str) -> None:
    with pytest.raises(InvalidNameError) as info:
        validate_name(name)
    assert info.value.index == index
    assert rule in str(info.value)


@pytest.mark.parametrize(
    ('name', 'rule'),
    [
        ('relative', 'a fully qualified name starts with "/"'),
        ('/a//b', 'must not contain "//"'),
        ('/a/1b', 'must not start with a digit'),
        ('/' + 'x' * 247, 'longer than 247'),
    ],
)
def test_invalid_full_names(name: str, rule: str) -> None:
    with pytest.raises(InvalidNameError, match=rule):
        validate_full_name(name)


def test_expanded_names_are_checked_as_full_names() -> None:
    with pytest.raises(InvalidNameError, match='must not contain "//"'):
        expand('a//b', 'node', '/')
    with pytest.raises(InvalidNameError, match='longer than 247'):
        expand('x' * 250, 'node', '/')


def test_namespaces_and_node_names() -> None:
    validate_namespace('/')
    validate_namespace('/robot/arm')
    with pytest.raises(InvalidNameError, match='must not end with "/"'):
        validate_namespace('/robot/')
    with pytest.raises(InvalidNameError, match='starts with "/"'):
        validate_namespace('robot')
    validate_node_name('R_demo')
    for bad, rule in (
        ('', 'empty'),
        ('2fast', 'digit'),
        ('a/b', 'only letters'),
        ('a b', 'only letters'),
    ):
        with pytest.raises(InvalidNameError, match=rule):
            validate_node_name(bad)


def test_remapping_rules() -> None:
    rules = Remapping.parse(
        ['chatter:=/other', 'talker:~/out:=renamed', '__ns:=/bot', '__node:=speaker']
    )
    assert rules.namespace == '/bot' and rules.node_name == 'speaker'
    assert rules.apply('/bot/chatter', 'talker', '/bot') == '/other'
    assert rules.apply('/bot/talker/out', 'talker', '/bot') == '/bot/renamed'
    assert rules.apply('/bot/listener/out', 'listener', '/bot') == '/bot/listener/out'  # other node
    assert rules.apply('/unrelated', 'talker', '/bot') == '/unrelated'
    assert Remapping.parse({'/a': '/b'}).apply('/a', 'n', '/') == '/b'
    with pytest.raises(ValueError, match='written "from:=to"'):
        Remapping.parse(['chatter=other'])
    with pytest.raises(InvalidNameError):
        Remapping.parse(['chatter:=bad name'])


def test_ros_args_are_split_from_the_command_line() -> None:
    parsed = parse_ros_args(
        ['prog', '--verbose', '--ros-args', '-r', 'a:=b', '--remap=c:=d', '-p', 'x:=1',
         '--param', 'use_sim_time:=true', '--params-file', 'p.yaml', '--log-level', 'debug',
         '--', 'tail', '-p']
    )  # fmt: skip
    assert parsed.rest == ('prog', '--verbose', 'tail', '-p')
    rules = parsed.remapping
    assert rules.apply('/a', 'n', '/') == '/b' and rules.apply('/c', 'n', '/') == '/d'
    assert parsed.parameters == {'x': '1', 'use_sim_time': 'true'}
    assert parsed.params_files == ('p.yaml',)
    assert parsed.log_level == 'debug'
    with pytest.raises(ValueError, match='needs a "from:=to"'):
        parse_ros_args(['--ros-args', '-r'])
    with pytest.raises(ValueError, match='written "name:=value"'):
        parse_ros_args(['--ros-args', '-p', 'oops'])
    with pytest.raises(ValueError, match='--log-level needs a value'):
        parse_ros_args(['--ros-args', '--log-level'])
