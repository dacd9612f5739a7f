"""Type resolution: name spellings, search paths, distros, built-ins and error messages."""

from __future__ import annotations

from pathlib import Path

import pytest

from zros import cdr
from zros.cdr.errors import TypeNameError, UnknownTypeError
from zros.cdr.interfaces import ActionType, ServiceType
from zros.cdr.registry import TypeRegistry, registry_of


@pytest.fixture
def registry() -> TypeRegistry:
    return TypeRegistry('jazzy', paths=[], ament=False)


@pytest.mark.parametrize(
    'spelling',
    [
        'geometry_msgs/msg/Twist',
        'geometry_msgs/Twist',
        'geometry_msgs::msg::Twist',
        'geometry_msgs::msg::dds_::Twist_',
        ' geometry_msgs/msg/Twist ',
    ],
)
def test_every_spelling_gives_the_same_class(registry: TypeRegistry, spelling: str) -> None:
    assert registry.get_type(spelling) is registry.get_class('geometry_msgs/msg/Twist')


def test_services_and_actions(registry: TypeRegistry) -> None:
    add = registry.get_type('example_interfaces/srv/AddTwoInts')
    assert isinstance(add, ServiceType)
    assert add.Request(a=2, b=3).b == 3
    assert add.Response.__msgtype__ == 'example_interfaces/srv/AddTwoInts_Response'
    assert add.Event is not None and 'info' in add.Event._fields
    assert registry.get_type('example_interfaces/AddTwoInts') is add  # ROS 1 style name
    fib = registry.get_type('example_interfaces/action/Fibonacci')
    assert isinstance(fib, ActionType)
    assert fib.Goal().order == 0
    assert fib.SendGoal.Request._fields == ('goal_id', 'goal')
    assert fib.GetResult.Response._fields == ('status', 'result')
    assert fib.FeedbackMessage._fields == ('goal_id', 'feedback')
    assert (
        registry.get_type('example_interfaces/action/Fibonacci_SendGoal_Request')
        is fib.SendGoal.Request
    )
    cancel = registry.get_service('action_msgs/srv/CancelGoal')
    assert cancel.Response.ERROR_GOAL_TERMINATED == 3
    describe = registry.get_service('type_description_interfaces/srv/GetTypeDescription')
    assert describe.Request().include_type_sources is True


def test_every_builtin_resolves(registry: TypeRegistry) -> None:
    from zros.cdr.builtin import builtin_names

    for name in builtin_names():
        resolved = registry.get_type(name)
        assert isinstance(resolved, (ServiceType, ActionType)), name


def test_humble_has_no_service_events_and_older_messages() -> None:
    humble = TypeRegistry('humble', ament=False)
    jazzy = TypeRegistry('jazzy', ament=False)
    assert humble.get_service('std_srvs/srv/Trigger').Event is None
    assert 'variance' not in humble.get_class('sensor_msgs/msg/Range')._fields
    assert 'variance' in jazzy.get_class('sensor_msgs/msg/Range')._fields


def test_distro_from_environment_and_bad_distro(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv('ZROS_DISTRO', 'Humble')
    assert TypeRegistry(ament=False).distro == 'humble'
    with pytest.raises(ValueError, match="unknown ROS distro 'galactic'; zros knows"):
        TypeRegistry('galactic')


def _write(root: Path, relative: str, text: str) -> None:
    path = root / relative
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_folder_layouts_on_the_interface_path(tmp_path: Path) -> None:
    _write(tmp_path / 'packages', 'alpha_msgs/msg/A.msg', 'int32 a\nbeta_msgs/B b')
    _write(tmp_path / 'beta_msgs', 'msg/B.msg', 'string name')
    _write(tmp_path / 'prefix', 'share/gamma_msgs/srv/G.srv', 'alpha_msgs/A a\n---\nbool ok')
    _write(tmp_path / 'prefix', 'share/gamma_msgs/action/Act.action', 'int8 g\n---\n---\n')
    registry = TypeRegistry(
        'jazzy',
        paths=[tmp_path / 'packages', tmp_path / 'beta_msgs', tmp_path / 'prefix'],
        ament=False,
    )
    a = registry.get_class('alpha_msgs/msg/A')(a=1, b={'name': 'x'})
    assert a.b.name == 'x'
    assert cdr.decode(type(a), cdr.encode(a)) == a
    assert registry.get_service('gamma_msgs/srv/G').Request().a.a == 0
    assert registry.get_action('gamma_msgs/action/Act').Goal().g == 0
    names = registry.names()
    for name in (
        'alpha_msgs/msg/A',
        'beta_msgs/msg/B',
        'gamma_msgs/srv/G',
        'gamma_msgs/action/Act',
    ):
        assert name in names


def test_environment_paths_and_precedence(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a user folder overrides the typestore; ZROS_INTERFACE_PATH wins over AMENT_PREFIX_PATH
    _write(tmp_path / 'user', 'std_msgs/msg/String.msg', 'string data\nint32 extra')
    _write(tmp_path / 'ament', 'share/std_msgs/msg/String.msg', 'string data\nint32 ament_extra')
    _write(tmp_path / 'ament', 'share/std_msgs/msg/Bool.msg', 'bool data\nint32 ament_only')
    monkeypatch.setenv('ZROS_INTERFACE_PATH', str(tmp_path / 'user'))
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path / 'ament'))
    registry = TypeRegistry('jazzy')
    assert registry.get_class('std_msgs/msg/String')._fields == ('data', 'extra')
    assert registry.get_class('std_msgs/msg/Bool')._fields == ('data', 'ament_only')
    assert TypeRegistry('jazzy', ament=False).get_class('std_msgs/msg/Bool')._fields == ('data',)


def test_registered_text_wins_and_conflicts_are_refused(registry: TypeRegistry) -> None:
    # a definition only loaded from the typestore is replaced silently
    assert registry.find('std_msgs/msg/Bool') is not None
    registry.register_text('std_msgs/msg/Bool', 'bool data\nbool more')
    assert registry.get_class('std_msgs/msg/Bool')._fields == ('data', 'more')
    # once a class exists, a different definition is refused unless replace=True
    with pytest.raises(ValueError, match='already defined differently'):
        registry.register_text('std_msgs/msg/Bool', 'bool data')
    registry.register_text('my_pkg/msg/Pair', 'int32 a\nint32 b')
    assert registry.get_class('my_pkg/msg/Pair')(a=1).a == 1
    registry.register_text('my_pkg/msg/Pair', 'int32 a\nint32 b')  # identical: fine
    with pytest.raises(ValueError, match='already defined differently'):
        registry.register_text('my_pkg/msg/Pair', 'int64 a')
    from zros.cdr.parser import parse_message

    registry.register(parse_message('my_pkg/msg/Pair', 'int64 a'), replace=True)
    assert registry.get_class('my_pkg/msg/Pair')._fields == ('a',)


def test_bundle_registration_keeps_known_dependencies(registry: TypeRegistry) -> None:
    text = (
        'std_msgs/Header header\nfloat32 v\n' + '=' * 80 + '\nMSG: std_msgs/Header\nuint8 broken\n'
    )
    registry.register_bundle('bag_msgs/msg/Reading', text)
    reading = registry.get_class('bag_msgs/msg/Reading')()
    assert reading.header.frame_id == ''  # the typestore's Header, not the bundle's


def test_unknown_type_lists_what_was_searched(registry: TypeRegistry, tmp_path: Path) -> None:
    with pytest.raises(UnknownTypeError) as info:
        registry.get_class('geometry_msgs/msg/Twis')
    text = str(info.value)
    assert "unknown ROS type 'geometry_msgs/msg/Twis'" in text
    assert 'ZROS_INTERFACE_PATH (not set)' in text
    assert 'rosbags typestore ros2_jazzy (162 messages)' in text
    assert 'Did you mean geometry_msgs/msg/Twist' in text
    assert 'geometry_msgs/msg/Twis.msg to a folder on ZROS_INTERFACE_PATH' in text
    with pytest.raises(UnknownTypeError, match='ZROS_INTERFACE_PATH entry'):
        TypeRegistry('jazzy', paths=[tmp_path], ament=False).get_class('nope_msgs/msg/Nope')


def test_nested_unknown_type_fails_when_the_class_is_built(registry: TypeRegistry) -> None:
    registry.register_text('my_pkg/msg/Outer', 'Missing inner')
    with pytest.raises(UnknownTypeError, match="'my_pkg/msg/Missing'"):
        registry.get_class('my_pkg/msg/Outer')


def test_kind_mismatch_and_bad_names(registry: TypeRegistry) -> None:
    with pytest.raises(TypeError, match='is not a service type'):
        registry.get_service('std_msgs/msg/String')
    with pytest.raises(TypeError, match='is not an action type'):
        registry.get_action('std_srvs/srv/Empty')
    with pytest.raises(TypeNameError, match='is not a ROS type name'):
        registry.get_type('not a type')


def test_a_class_knows_the_registry_that_built_it(registry: TypeRegistry) -> None:
    assert registry_of(registry.get_class('std_msgs/msg/String')) is registry
    assert registry_of(cdr.get_class('std_msgs/msg/String')) is cdr.default_registry()

    class Handmade(cdr.Message):
        __msgtype__ = 'my_msgs/msg/Handmade'

    with pytest.raises(TypeError, match='Handmade was not built by a TypeRegistry'):
        registry_of(Handmade)


def test_module_level_helpers() -> None:
    msg = cdr.new_message('std_msgs/String', data='hi')
    assert cdr.decode('std_msgs/msg/String', cdr.encode(msg)).data == 'hi'
    assert cdr.get_class(type(msg)) is type(msg)


def test_typestore_messages_keep_ros_defaults() -> None:
    # the rosbags typestores drop default values; zros restores the ones that are not zero
    for distro in ('humble', 'jazzy'):
        registry = TypeRegistry(distro, ament=False)
        assert registry.get_class('geometry_msgs/msg/Quaternion')().w == 1.0
        assert registry.get_class('geometry_msgs/msg/Pose')().orientation.w == 1.0
    assert (
        TypeRegistry('jazzy', ament=False).get_class('sensor_msgs/msg/NavSatStatus')().status == -2
    )
    assert (
        TypeRegistry('humble', ament=False).get_class('sensor_msgs/msg/NavSatStatus')().status == 0
    )


def test_decode_by_name_follows_the_default_registry_and_replaced_definitions() -> None:
    from zros.cdr.parser import parse_definition
    from zros.cdr.registry import default_registry, set_default_registry

    previous = default_registry()
    mine = TypeRegistry(paths=[])
    mine.register_text('speed_test/msg/Value', 'int32 value')
    data = cdr.encode(mine.get_class('speed_test/msg/Value')(value=7))
    try:
        set_default_registry(mine)
        decoded = cdr.decode('speed_test/msg/Value', data)
        assert type(decoded) is mine.get_class('speed_test/msg/Value')
        assert cdr.decode('speed_test/Value', data).value == 7  # another spelling
        # replacing the definition drops the decoders cached for every spelling
        replacement = parse_definition('speed_test/msg/Value', 'uint16 value\nuint16 other', '')
        mine.register(replacement, replace=True)
        for spelling in ('speed_test/msg/Value', 'speed_test/Value'):
            decoded = cdr.decode(spelling, data)
            assert type(decoded) is mine.get_class('speed_test/msg/Value')
            assert (decoded.value, decoded.other) == (7, 0)
    finally:
        set_default_registry(previous)
    # back to a registry that never heard of the type: the cache went with the registry
    with pytest.raises(UnknownTypeError):
        cdr.decode('speed_test/msg/Value', data)
