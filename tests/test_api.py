"""The rosR-shaped module API on the default node."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest

import zros
from zros.node import Node
from zros.testing import wait_for
from zros.transport import Router, Transport


@pytest.fixture
def initialized(zros_router: Router) -> Iterator[zros.Node]:
    node = zros.init('R_demo', connect=zros_router.endpoint, handle_sigint=False)
    try:
        yield node
    finally:
        zros.shutdown()


def test_the_rosr_loop(initialized: zros.Node, zros_node: Callable[..., Node]) -> None:
    sensor = zros_node('sensor').create_publisher('std_msgs/msg/Float32', '/sharpGP2D120/Voltage')
    sub = zros.Subscriber('/sharpGP2D120/Voltage', 'std_msgs/msg/Float32')
    pub = zros.Publisher('/sharpGP2D120/Distance', 'sensor_msgs/msg/Range')
    out = zros_node('monitor').create_subscription(
        'sensor_msgs/msg/Range', '/sharpGP2D120/Distance'
    )
    rng = zros.Message('sensor_msgs/msg/Range', min_range=0.04, max_range=0.3)
    assert sensor.wait_for_subscribers() and pub.wait_for_subscribers()
    sensor.write(zros.Message('std_msgs/msg/Float32', data=0.8))
    handled = 0
    while zros.ok() and handled < 1:
        zros.spin_once(timeout=0.05)
        if sub.has_new_message():
            volt = sub.read_message().data
            rng.range = 0.2 / volt
            pub.write(rng)
            handled += 1
    assert wait_for(out.has_new_message)
    assert out.read_message().range == pytest.approx(0.25, rel=1e-6)


def test_init_twice_needs_shutdown(initialized: zros.Node, zros_router: Router) -> None:
    assert zros.default_node() is initialized and zros.ok()
    with pytest.raises(zros.ZrosError, match='already called'):
        zros.init('again', connect=zros_router.endpoint)
    zros.shutdown()
    assert not zros.ok()
    node = zros.init('again', connect=zros_router.endpoint, handle_sigint=False)
    assert node.name == 'again' and zros.ok()


def test_module_calls_need_init() -> None:
    zros.shutdown()
    assert not zros.ok()
    with pytest.raises(zros.NotInitializedError, match=r'call zros.init\("my_node"\) first'):
        zros.spin_once()
    with pytest.raises(zros.NotInitializedError):
        zros.Subscriber('chatter', 'std_msgs/msg/String')


def test_init_passes_connection_settings_on(zros_router: Router) -> None:
    node = zros.init(
        'laptop', connect=zros_router.endpoint, shared_memory=False, handle_sigint=False
    )
    try:
        assert node.transport.config.shared_memory is False
        assert node.transport.config.connect == (zros_router.endpoint,)
    finally:
        zros.shutdown()


def test_connection_settings_in_one_place_only(zros_transport: Callable[..., Transport]) -> None:
    config = zros.transport.TransportConfig.create(connect='tcp/127.0.0.1:1')
    with pytest.raises(TypeError, match='in config=, not beside it'):
        zros.Node('confused', config=config, shared_memory=False)
    with pytest.raises(TypeError, match='takes no connection settings'):
        zros.Node('confused', transport=zros_transport(), connect='tcp/127.0.0.1:1')
    with pytest.raises(TypeError, match='unexpected keyword'):
        zros.Node('confused', conect='tcp/127.0.0.1:7447')


# --- one way per task: the old spellings still work, and say what replaces them ---------------


def test_timer_takes_the_node_as_a_keyword_and_the_default_node_without(
    initialized: zros.Node, zros_node: Callable[..., Node]
) -> None:
    ticks: list[str] = []
    on_default = zros.Timer(0.01, lambda: ticks.append('default'))
    assert on_default.node is initialized
    other = zros_node('other')
    on_other = zros.Timer(0.01, lambda: ticks.append('other'), node=other)
    assert on_other.node is other
    with pytest.warns(DeprecationWarning, match=r'Timer\(node, period, callback\) is deprecated'):
        old = zros.Timer(other, 0.01, lambda: ticks.append('old'))
    assert old.node is other and old.period == 0.01
    assert wait_for(lambda: zros.spin_once(0.02) >= 0 and 'default' in ticks)
    assert wait_for(lambda: other.spin_once(0.02) >= 0 and {'other', 'old'} <= set(ticks))
    with pytest.raises(TypeError, match=r'Timer takes \(period, callback, node=None\)'):
        zros.Timer('fast', lambda: None)  # type: ignore[call-overload]
    with pytest.raises(TypeError, match='node= takes a node, not str'):
        zros.Timer(0.01, lambda: None, node='other')  # type: ignore[call-overload]


def test_timer_without_a_node_needs_init() -> None:
    with pytest.raises(zros.NotInitializedError):
        zros.Timer(0.01, lambda: None)


def test_rate_takes_the_node_as_a_keyword(zros_node: Callable[..., Node]) -> None:
    node = zros_node('rated')
    assert zros.Rate(50, node=node).node is node
    assert zros.Rate(50).node is None  # no node: a plain sleep on the monotonic clock
    with pytest.warns(DeprecationWarning, match=r'Rate\(hz, node\) is deprecated'):
        old = zros.Rate(50, node)
    assert old.node is node
    with pytest.raises(TypeError, match=r'Rate takes \(hz, node=None\)'):
        zros.Rate(50, node, node=node)


def test_node_waits_for_publishers_and_subscribers_in_the_plural(
    zros_node: Callable[..., Node],
) -> None:
    viewer, other = zros_node('viewer'), zros_node('other')
    assert not viewer.wait_for_publishers('plural', timeout=0.05)
    assert not viewer.wait_for_subscribers('plural', timeout=0.05)
    other.create_publisher('std_msgs/msg/String', 'plural')
    other.create_subscription('std_msgs/msg/String', 'plural')
    assert viewer.wait_for_publishers('plural') and viewer.wait_for_subscribers('plural')
    with pytest.warns(DeprecationWarning, match='use Node.wait_for_publishers'):
        assert viewer.wait_for_publisher('plural')
    with pytest.warns(DeprecationWarning, match='use Node.wait_for_subscribers'):
        assert viewer.wait_for_subscriber('plural')


def test_parameter_client_takes_the_node_as_a_keyword(
    initialized: zros.Node, zros_node: Callable[..., Node]
) -> None:
    driver = zros_node('driver')
    driver.declare_parameter('speed', 0.5)
    client = zros.ParameterClient('/driver')
    assert client.node is initialized and client.get('speed') == 0.5
    tool = zros_node('tool')
    assert zros.ParameterClient('driver', node=tool, timeout=2.0).node is tool
    with pytest.warns(DeprecationWarning, match=r'ParameterClient\(node, node_name\) is depr'):
        old = zros.ParameterClient(tool, '/driver', 2.0)
    assert old.node is tool and old.timeout == 2.0 and old.get('speed') == 0.5
    with pytest.raises(TypeError, match=r'ParameterClient takes \(node_name, node=None'):
        zros.ParameterClient('/driver', 2.0)
    with pytest.raises(TypeError, match=r'ParameterClient takes \(node_name, node=None'):
        zros.ParameterClient(tool, '/driver', node=tool)


ROS_ARGS = ['--ros-args', '-p', 'speed:=2.5', '-r', '__ns:=/bot', '-r', 'chatter:=talk']


def test_init_arguments_apply_to_every_node_as_rclpys_global_arguments(
    zros_router: Router, zros_node: Callable[..., Node]
) -> None:
    zros.init(args=['talker.py', *ROS_ARGS], connect=zros_router.endpoint, handle_sigint=False)
    try:
        talker = zros.Node('talker')
        assert talker.get_fully_qualified_name() == '/bot/talker'
        assert talker.declare_parameter('speed', 1.0) == 2.5
        assert talker.resolve_name('chatter') == '/bot/talk'
        # a node's own arguments go on top of the global ones
        own = zros.Node('own', args=['--ros-args', '-p', 'speed:=3.0', '-r', 'chatter:=mine'])
        assert own.get_fully_qualified_name() == '/bot/own'
        assert own.declare_parameter('speed', 1.0) == 3.0
        assert own.resolve_name('chatter') == '/bot/mine'
        plain = zros.Node('plain', use_global_arguments=False)
        assert plain.get_fully_qualified_name() == '/plain'
        assert plain.resolve_name('chatter') == '/chatter'
    finally:
        zros.shutdown()
    after = zros_node('after')
    assert after.get_fully_qualified_name() == '/after'
    assert after.declare_parameter('speed', 1.0) == 1.0


def test_init_without_args_reads_sys_argv_and_skips_the_programs_own(
    zros_router: Router, monkeypatch: pytest.MonkeyPatch
) -> None:
    argv = ['talker.py', '-p', 'input.txt', '--verbose', *ROS_ARGS, '--', '-r', 'x']
    monkeypatch.setattr('sys.argv', argv)
    node = zros.init('talker', connect=zros_router.endpoint, handle_sigint=False)
    try:
        assert node.get_fully_qualified_name() == '/bot/talker'
        assert node.declare_parameter('speed', 1.0) == 2.5
        assert zros.Node('second').resolve_name('chatter') == '/bot/talk'
    finally:
        zros.shutdown()


@pytest.mark.parametrize(
    ('args', 'error', 'match'),
    [
        (['--ros-args', '-p', 'speed'], ValueError, 'name:=value'),
        (['--ros-args', '-p', 'x:=[1,'], zros.ParameterError, 'not valid YAML'),
        (['--ros-args', '--params-file', '/no/such.yaml'], zros.ParameterError, 'cannot read'),
        (['--ros-args', '-r', 'chatter'], ValueError, 'from:=to'),
        (['--ros-args', '--log-level', 'loud'], ValueError, 'loud'),
    ],
)
def test_init_refuses_malformed_ros_arguments_and_leaves_nothing_behind(
    zros_router: Router,
    zros_node: Callable[..., Node],
    args: list[str],
    error: type[Exception],
    match: str,
) -> None:
    try:
        with pytest.raises(error, match=match):
            zros.init(args=args, connect=zros_router.endpoint, handle_sigint=False)
    finally:
        zros.shutdown()  # zros.init without the fix accepted them
    assert not zros.ok()
    assert zros_node('fine').get_fully_qualified_name() == '/fine'
