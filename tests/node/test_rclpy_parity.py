"""rclpy code ports as docs/mapping.md says: rclpy's node methods, Node subclasses, spinning that
Ctrl-C ends cleanly, and ``zros.init(args=...)`` adding no node of its own to the graph."""

from __future__ import annotations

import concurrent.futures
import signal
import time
from collections.abc import Callable, Iterator

import pytest

import zros
from tests.support.processes import Script, sleeping
from zros import Parameter
from zros.graph import Endpoint, TopicEndpointInfo, TopicEndpointType
from zros.keyexpr.kinds import EntityKind
from zros.node import Node, NodeNameNonExistentError
from zros.testing import wait_for
from zros.transport import Router


def test_names_as_rclpy_spells_them(zros_node: Callable[..., Node]) -> None:
    node = zros_node('talker', '/robot')
    assert node.get_name() == 'talker'
    assert node.get_namespace() == '/robot'
    assert node.get_fully_qualified_name() == '/robot/talker'
    assert zros_node('root').get_namespace() == '/'


def test_destroy_entities_as_rclpy_does(zros_node: Callable[..., Node]) -> None:
    node, other = zros_node('owner'), zros_node('other')
    publisher = node.create_publisher('std_msgs/msg/String', 'chatter', 10)
    subscription = node.create_subscription('std_msgs/msg/String', 'chatter', None, 10)
    service = node.create_service('std_srvs/srv/Trigger', 'trigger')
    client = node.create_client('std_srvs/srv/Trigger', 'trigger')
    timer = node.create_timer(0.01, lambda: None)
    assert wait_for(lambda: node.count_subscribers('/chatter') == 1)
    # another node's entity, or the wrong kind, is refused (False), as rclpy does
    assert not other.destroy_publisher(publisher)
    assert not node.destroy_subscription(publisher)  # type: ignore[arg-type]
    assert not other.destroy_timer(timer)
    assert node.destroy_publisher(publisher)
    assert node.destroy_subscription(subscription)
    assert node.destroy_service(service)
    assert node.destroy_client(client)
    assert node.destroy_timer(timer) and timer.cancelled
    assert node.context.entities == [] or all(
        entity not in node.context.entities for entity in (publisher, subscription, service, client)
    )
    assert wait_for(lambda: other.count_subscribers('/chatter') == 0)
    # twice: already destroyed
    assert not node.destroy_publisher(publisher)
    assert not node.destroy_timer(timer)
    node.destroy_node()
    assert not node.ok()


PUBLISHER = """
import zros
from zros import Node

String = zros.get_type('std_msgs/msg/String')


class MinimalPublisher(Node):
    def __init__(self):
        super().__init__('minimal_publisher')
        self.publisher_ = self.create_publisher(String, 'topic', 10)
        self.timer = self.create_timer(0.05, self.timer_callback)
        self.i = 0

    def timer_callback(self):
        msg = String()
        msg.data = f'Hello World: {self.i}'
        self.publisher_.publish(msg)
        self.get_logger().info(f'Publishing: "{msg.data}"')
        self.i += 1

"""

SUBSCRIBER = """
import zros
from zros import Node

String = zros.get_type('std_msgs/msg/String')


class MinimalSubscriber(Node):
    def __init__(self):
        super().__init__('minimal_subscriber')
        self.subscription = self.create_subscription(
            String, 'topic', self.listener_callback, 10)

    def listener_callback(self, msg):
        print(f'I heard: "{msg.data}"', flush=True)

"""

#: rclpy's main() of either example: {node} is minimal_publisher or minimal_subscriber
MAIN = """
def main(args=None):
    {init}
    {node} = {cls}()
    print('spinning', flush=True)
    {spin}
    {node}.destroy_node()
    {shutdown}
    print('ended', flush=True)


main()
"""

STYLES = {
    # rclpy's own shape: init(args=args), spin(node), shutdown()
    'zros.init(args=args)': ('zros.init(args=args)', 'zros.spin({node})', 'zros.shutdown()'),
    # no init at all: Ctrl-C reaches spin as Python's KeyboardInterrupt
    'without init': ('pass', '{node}.spin()', 'pass'),
}


@pytest.fixture
def scripts() -> Iterator[list[Script]]:
    started: list[Script] = []
    yield started
    for script in started:
        script.stop()


@pytest.mark.parametrize('style', STYLES)
def test_minimal_examples_run_and_end_on_ctrl_c(
    style: str, zros_router: Router, zros_node: Callable[..., Node], scripts: list[Script]
) -> None:
    init, spin, shutdown = STYLES[style]
    for code, cls, node in (
        (SUBSCRIBER, 'MinimalSubscriber', 'minimal_subscriber'),
        (PUBLISHER, 'MinimalPublisher', 'minimal_publisher'),
    ):
        main = MAIN.replace('{init}', init).replace('{spin}', spin).replace('{shutdown}', shutdown)
        main = main.replace('{cls}', cls).replace('{node}', node)
        scripts.append(Script(code + main, zros_router))
        scripts[-1].expect('spinning', 30)
    subscriber = scripts[0]
    subscriber.expect('I heard: "Hello World: ', 30)
    observer = zros_node('observer')
    assert wait_for(
        lambda: {'/minimal_publisher', '/minimal_subscriber'} <= set(observer.get_node_names())
    )
    # zros.init(args=...) made no node of its own: only the two nodes and the observer
    assert set(observer.get_node_names()) == {
        '/minimal_publisher',
        '/minimal_subscriber',
        '/observer',
    }
    for script in scripts:
        script.process.send_signal(signal.SIGINT)
    for script in scripts:
        script.expect('ended', 10)
        assert script.process.wait(10) == 0
        errors = script.stop()
        assert 'Traceback' not in errors, errors


def test_init_without_a_name_makes_the_default_node_when_needed(zros_router: Router) -> None:
    assert zros.init(connect=zros_router.endpoint, handle_sigint=False) is None
    try:
        assert zros.ok()
        own = zros.Node('own')  # on the session init's connect= opened
        assert wait_for(lambda: '/own' in own.get_node_names())
        assert own.get_node_names() == ['/own']
        publisher = zros.Publisher('/lazy', 'std_msgs/msg/String')
        assert publisher.node.transport is own.transport
        assert publisher.node is zros.default_node()
        assert zros.default_node().get_fully_qualified_name() == '/zros'
        with pytest.raises(zros.ZrosError, match='already called'):
            zros.init(connect=zros_router.endpoint, handle_sigint=False)
    finally:
        zros.shutdown()
    assert not zros.ok()


ADD = 'example_interfaces/srv/AddTwoInts'
FIBONACCI = 'example_interfaces/action/Fibonacci'


def test_waits_and_calls_take_rclpys_timeout_sec(zros_node: Callable[..., Node]) -> None:
    server = zros_node('server', immediate_callbacks=True)  # answers without spinning
    caller = zros_node('caller')
    client = caller.create_client(ADD, '/add')
    actions = caller.create_action_client(FIBONACCI, '/fibonacci')
    assert not client.wait_for_service(timeout_sec=0.05)
    assert not actions.wait_for_server(timeout_sec=0.05)
    add = zros.get_type(ADD)
    server.create_service(ADD, '/add', lambda request: add.Response(sum=request.a + request.b))
    server.create_action_server(FIBONACCI, '/fibonacci', lambda goal: None)  # no goal comes
    assert client.wait_for_service(timeout_sec=30.0)
    assert actions.wait_for_server(timeout_sec=30.0)
    assert client.call(a=1, b=2, timeout_sec=30.0).sum == 3
    for both in (
        lambda: client.wait_for_service(1.0, timeout_sec=1.0),
        lambda: actions.wait_for_server(1.0, timeout_sec=1.0),
        lambda: client.call(a=1, timeout=1.0, timeout_sec=1.0),
    ):
        with pytest.raises(TypeError, match="give timeout= or rclpy's timeout_sec=, not both"):
            both()


def test_module_spin_once_takes_a_node_as_rclpys(zros_node: Callable[..., Node]) -> None:
    node = zros_node('spun')
    ticks: list[int] = []
    node.create_timer(0.01, lambda: ticks.append(1))
    # each returns after one run (or a wake-up of the node): the node's timer is what runs
    assert wait_for(lambda: zros.spin_once(node, timeout_sec=30.0) == 1)
    assert wait_for(lambda: zros.spin_once(node) == 1)  # rclpy's default: until one runs
    assert wait_for(lambda: zros.spin_once(node, 30.0) == 1) and len(ticks) >= 3
    with pytest.raises(TypeError, match='not both'):
        zros.spin_once(node, 1.0, timeout_sec=1.0)
    with pytest.raises(TypeError, match='not two timeouts'):
        zros.spin_once(0.1, 0.2)


def test_module_spin_once_takes_timeout_sec_on_the_default_node(zros_router: Router) -> None:
    zros.init('default', connect=zros_router.endpoint, handle_sigint=False)
    try:
        ticks: list[int] = []
        zros.default_node().create_timer(0.01, lambda: ticks.append(1))
        assert wait_for(lambda: zros.spin_once(timeout_sec=0.05) == 1)
        assert wait_for(lambda: zros.spin_once(0.05) == 1)
        assert zros.spin_once() in (0, 1)  # zros's default timeout: 0, no wait
    finally:
        zros.shutdown()


def test_an_unknown_node_keyword_names_node_and_its_keywords() -> None:
    # it reached TransportConfig, which reported it as its own
    with pytest.raises(
        TypeError,
        match=r"Node\(\) got an unexpected keyword argument 'parameter_overrides' "
        r"\(rclpy's: for parameter_overrides write parameters=\{'name': value\}\); "
        r'it takes name, namespace and allow_undeclared_parameters, args, .*use_sim_time',
    ):
        zros.Node('x', parameter_overrides=[])  # type: ignore[call-arg]
    with pytest.raises(
        TypeError, match=r"unexpected keyword arguments 'bogus', 'cli_args' .*args="
    ):
        zros.Node('x', cli_args=[], bogus=1)  # type: ignore[call-arg]


LOOPS = {
    'spin': 'node.spin(timeout=0.5)',
    'spin_once': 'node.spin_once(timeout=0.5)',
    'rate': 'rate.sleep()',
}


@pytest.mark.parametrize('loop', LOOPS)
def test_ctrl_c_ends_a_while_ok_loop_without_init(
    loop: str, zros_router: Router, scripts: list[Script]
) -> None:
    # as with zros.init's handler: Ctrl-C ends the wait and ok() turns false
    code = (
        'import zros\n'
        "node = zros.Node('looping')\n"
        'rate = node.create_rate(10)\n'
        "print('looping', flush=True)\n"
        'while node.ok():\n'
        f'    {LOOPS[loop]}\n'
        "print('left the loop', node.ok(), flush=True)\n"
        'node.destroy()\n'
    )
    scripts.append(Script(code, zros_router))
    script = scripts[-1]
    script.expect('looping', 30)
    assert wait_for(lambda: sleeping(script.process.pid), 10)
    script.process.send_signal(signal.SIGINT)
    assert script.expect('left the loop', 10)[1] == 'left the loop False'
    assert script.process.wait(10) == 0
    errors = script.stop()
    assert 'Traceback' not in errors, errors


def test_spin_once_timeout_sec_and_get_parameter_or(zros_node: Callable[..., Node]) -> None:
    """rclpy's spellings: ``node.spin_once(timeout_sec=)`` and ``get_parameter_or``."""
    node = zros_node('parity_or')
    ran: list[int] = []
    node.create_timer(0.01, lambda: ran.append(1))
    assert wait_for(lambda: node.spin_once(timeout_sec=1.0) > 0, timeout=10.0)
    with pytest.raises(TypeError, match='not both'):
        node.spin_once(0.5, timeout_sec=1.0)
    node.declare_parameter('speed', 1.5)
    assert node.get_parameter_or('speed', 9.0) == 1.5
    assert node.get_parameter_or('missing', 9.0) == 9.0
    assert node.get_parameter_or('missing') is None


def test_spin_until_future_complete_runs_the_node_until_the_answer(
    zros_node: Callable[..., Node],
) -> None:
    """rclpy's ``spin_until_future_complete``: the node's own service answers while it spins."""
    node = zros_node('waiter')
    add = zros.get_type(ADD)
    node.create_service(ADD, '/sum', lambda request: add.Response(sum=request.a + request.b))
    client = node.create_client(ADD, '/sum')
    assert client.wait_for_service(timeout_sec=30.0)
    future = client.call_async(add.Request(a=2, b=3))
    started = time.monotonic()
    zros.spin_until_future_complete(node, future, timeout_sec=30.0)
    # the answer (from Zenoh's thread) woke the spin: it did not wait out its timeout
    assert future.done() and time.monotonic() - started < 20.0
    assert future.result().sum == 5
    # the same on the node's executor, and with rclpy's executor= naming that executor
    future = client.call_async(add.Request(a=4, b=4))
    node.context.executor.spin_until_future_complete(future, 30.0)
    assert future.result().sum == 8
    future = client.call_async(add.Request(a=1, b=1))
    zros.spin_until_future_complete(node, future, executor=node.context.executor)
    assert future.result().sum == 2


def test_spin_until_future_complete_ends_at_its_timeout(zros_node: Callable[..., Node]) -> None:
    node = zros_node('patient')
    ticks: list[int] = []
    node.create_timer(0.01, lambda: ticks.append(1))
    never: concurrent.futures.Future[int] = concurrent.futures.Future()
    zros.spin_until_future_complete(node, never, timeout_sec=0.3)
    assert not never.done() and ticks  # it ran the node's timer meanwhile
    zros.spin_until_future_complete(node, never, timeout_sec=0)  # 0: what is due, no wait
    node.spin_until_future_complete(never, timeout=0.01)  # zros's spelling, on the node
    with pytest.raises(TypeError, match='not both'):
        node.spin_until_future_complete(never, 1.0, timeout_sec=1.0)
    done: concurrent.futures.Future[int] = concurrent.futures.Future()
    done.set_result(1)
    zros.spin_until_future_complete(node, done)  # no timeout, but done already
    # another node's executor would not run this node: refused, as the error says
    with pytest.raises(ValueError, match='runs on its own executor'):
        zros.spin_until_future_complete(node, done, executor=zros_node('other').context.executor)


def test_graph_names_and_types_by_node(zros_node: Callable[..., Node]) -> None:
    # without parameter services (and their /parameter_events): the node's own entities only
    owner = zros_node('owner', '/robot', start_parameter_services=False)
    observer = zros_node('observer')
    owner.create_publisher('std_msgs/msg/String', 'out', 10)
    owner.create_subscription('std_msgs/msg/Int32', 'in', None, 10)
    owner.create_service(ADD, 'add')
    owner.create_client('std_srvs/srv/Trigger', '/trigger')
    assert wait_for(
        lambda: ('/trigger', ['std_srvs/srv/Trigger']) in observer.get_service_names_and_types(),
        timeout=30.0,
    )
    assert ('/robot/add', [ADD]) in observer.get_service_names_and_types()
    assert observer.get_publisher_names_and_types_by_node('owner', '/robot') == [
        ('/robot/out', ['std_msgs/msg/String'])
    ]
    assert observer.get_subscriber_names_and_types_by_node('owner', '/robot') == [
        ('/robot/in', ['std_msgs/msg/Int32'])
    ]
    assert observer.get_service_names_and_types_by_node('owner', '/robot') == [
        ('/robot/add', [ADD])
    ]
    assert observer.get_client_names_and_types_by_node('owner', '/robot') == [
        ('/trigger', ['std_srvs/srv/Trigger'])
    ]
    assert observer.get_publisher_names_and_types_by_node('observer', '/') == [
        ('/parameter_events', ['rcl_interfaces/msg/ParameterEvent'])
    ]
    with pytest.raises(NodeNameNonExistentError, match='node /robot/nobody is not in the graph'):
        observer.get_publisher_names_and_types_by_node('nobody', '/robot')


def test_logger_takes_rclpys_filter_keywords(zros_node: Callable[..., Node]) -> None:
    logger = zros_node('filtered').get_logger()
    assert [logger.info('once', once=True) for _ in range(3)] == [True, False, False]
    assert [logger.warn('skip', skip_first=True) for _ in range(3)] == [False, True, True]
    throttled = [logger.info('tick', throttle_duration_sec=3600.0) for _ in range(3)]
    assert throttled == [True, False, False]
    # per call site, as rclpy's: two calls on one line are two sites
    assert [(logger.info('a', once=True), logger.info('b', once=True)) for _ in range(2)] == [
        (True, True),
        (False, False),
    ]
    # rclpy's order: a throttled call does not count for skip_first
    first = [logger.info('t', throttle_duration_sec=3600.0, skip_first=True) for _ in range(3)]
    assert first == [False, False, False]
    # a throttle on another clock: the node's sim clock, which stands still
    sim = zros_node('still', use_sim_time=True)
    on_sim = [
        logger.info('sim', throttle_duration_sec=1.0, throttle_time_source_type=sim.get_clock())
        for _ in range(2)
    ]
    assert on_sim == [True, False]
    assert logger.info('zero', throttle_duration_sec=0.0) and logger.info('zero', throttle=None)
    with pytest.raises(TypeError, match='not both'):
        logger.info('both', throttle=1.0, throttle_duration_sec=1.0)


def test_time_and_timer_answer_as_rclpys(zros_node: Callable[..., Node]) -> None:
    assert zros.Time(seconds=3, nanoseconds=25).seconds_nanoseconds() == (3, 25)
    assert zros.Time(-1).seconds_nanoseconds() == (-1, 999_999_999)
    node = zros_node('timed')
    ticks: list[int] = []
    timer = node.create_timer(3600.0, lambda: ticks.append(1))
    assert timer.timer_period_ns == 3600 * 10**9
    assert not timer.is_ready() and not timer.is_canceled()
    left = timer.time_until_next_call()
    assert left is not None and 3500 * 10**9 < left <= 3600 * 10**9
    assert 0 <= timer.time_since_last_call() < 100 * 10**9
    fast = node.create_timer(0.001, lambda: ticks.append(2))
    assert wait_for(fast.is_ready)
    left = fast.time_until_next_call()
    assert left is not None and left <= 0  # overdue: the next spin runs it
    assert node.spin_once() >= 1 and 2 in ticks
    fast.timer_period_ns = 3600 * 10**9
    assert fast.timer_period_ns == 3600 * 10**9 and fast.period == 3600.0
    assert wait_for(lambda: not fast.is_ready())  # the call due ran; the next is an hour away
    with pytest.raises(ValueError, match='period must be positive'):
        fast.timer_period_ns = 0
    timer.cancel()
    assert timer.is_canceled() and not timer.is_ready()
    assert timer.time_until_next_call() is None


def test_rclpys_parameter_objects(zros_node: Callable[..., Node]) -> None:
    """``zros.Parameter`` as rclpy builds it, taken where rclpy's node takes one."""
    node = zros_node('configured')
    assert node.declare_parameters(
        '', [('speed', 1.5), ('mode', 'fast'), ('limit', Parameter.Type.INTEGER)]
    ) == [
        Parameter('speed', Parameter.Type.DOUBLE, 1.5),
        Parameter('mode', value='fast'),
        Parameter('limit', Parameter.Type.NOT_SET),
    ]
    # declared by type only: no value yet, and only an integer may be set
    assert not node.set_parameters([Parameter('limit', value='high')])[0]
    assert node.set_parameters([Parameter('limit', value=5)])[0]
    ranged = zros.Descriptor(integer_range=(0, 10, 1))
    (level,) = node.declare_parameters('arm', [('level', 3, ranged)])
    assert (level.name, level.value, level.type_) == ('arm.level', 3, Parameter.Type.INTEGER)
    assert node.declare_parameters([Parameter('gain', value=2.0)]) == {'gain': 2.0}
    seen: list[tuple[str, object, zros.ParameterType]] = []

    def check(changes: list[zros.params.Parameter]) -> bool:
        seen.extend((change.name, change.value, change.type_) for change in changes)
        return all(change.type_ == Parameter.Type.DOUBLE for change in changes)

    node.add_on_set_parameters_callback(check)
    results = node.set_parameters(
        [Parameter('speed', Parameter.Type.DOUBLE, 2.5), Parameter('mode', value='slow')]
    )
    assert [result.successful for result in results] == [True, False]
    assert seen == [('speed', 2.5, Parameter.Type.DOUBLE), ('mode', 'slow', Parameter.Type.STRING)]
    # get_parameter keeps returning the value (zros's promise, docs/mapping.md)
    assert node.get_parameter('speed') == 2.5 and node.get_parameter('mode') == 'fast'
    # all or none: the refused one keeps the other from being set
    assert not node.set_parameters_atomically(
        [Parameter('gain', value=3.0), Parameter('mode', value='x')]
    )
    assert node.get_parameter('gain') == 2.0
    assert node.set_parameters_atomically([Parameter('gain', value=4.0)])
    assert node.get_parameter('gain') == 4.0
    # a value that does not agree with its type, or a type that is not one, as rclpy says
    with pytest.raises(ValueError, match="Type INTEGER and value 'a' do not agree"):
        Parameter('x', Parameter.Type.INTEGER, 'a')
    with pytest.raises(ValueError, match='Type DOUBLE and value 2 do not agree'):
        Parameter('speed', Parameter.Type.DOUBLE, 2)  # an int for a double, refused as by rclpy
    with pytest.raises(ValueError, match=r'Type DOUBLE_ARRAY and value \[1, 2\] do not agree'):
        Parameter('gains', Parameter.Type.DOUBLE_ARRAY, [1, 2])
    with pytest.raises(TypeError, match=r'not 2.0 \(a value goes as value=.*value=2.0\)'):
        Parameter('x', 2.0)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="parameter 'x': dict is not a parameter type"):
        Parameter('x', value={})
    with pytest.raises(TypeError, match='takes a namespace first'):
        node.declare_parameters({'a': 1}, [('b', 2)])  # type: ignore[call-overload]
    with pytest.raises(TypeError, match='needs the parameters'):
        node.declare_parameters('ns')  # type: ignore[call-overload]
    # rclpy's byte array (a list of one-byte bytes) and its message form
    assert Parameter('raw', value=[b'a', b'b']).value == b'ab'
    message_class = zros.get_type('rcl_interfaces/msg/Parameter')
    message = message_class(name='n', value={'type': 2, 'integer_value': 7})
    assert Parameter.from_parameter_msg(message) == Parameter('n', value=7)


def test_more_graph_names_as_rclpys(zros_node: Callable[..., Node]) -> None:
    node = zros_node('mapper', '/robot', remap=['chatter:=/talk'])
    observer = zros_node('observer')
    assert node.resolve_topic_name('chatter') == '/talk'
    assert node.resolve_topic_name('chatter', only_expand=True) == '/robot/chatter'
    assert node.resolve_topic_name('~/state') == '/robot/mapper/state'
    assert node.resolve_service_name('add') == '/robot/add'
    assert node.resolve_service_name('~/add', only_expand=True) == '/robot/mapper/add'
    with pytest.raises(zros.InvalidNameError):
        node.resolve_service_name('bad name')
    node.create_service(ADD, 'add')
    observer.create_client(ADD, '/robot/add')
    assert observer.wait_for_node('/robot/mapper', timeout=30.0)
    assert observer.wait_for_node('observer', timeout=30.0)  # no leading /: at the root
    assert not observer.wait_for_node('/robot/absent', timeout=0.05)
    assert wait_for(lambda: observer.count_clients('/robot/add') == 1, timeout=30.0)
    assert wait_for(lambda: observer.count_services('/robot/add') == 1, timeout=30.0)
    assert node.count_services('add') == 1 and observer.count_services('/add') == 0
    assert '/robot/mapper' in observer.get_fully_qualified_node_names()
    names = observer.get_node_names_and_namespaces()
    assert ('mapper', '/robot') in names and ('observer', '/') in names


def test_more_parameter_names_as_rclpys(zros_node: Callable[..., Node]) -> None:
    node = zros_node('described')
    node.declare_parameter('level', 3, integer_range=(0, 10, 1), description='how high')
    assert node.get_parameter_type('level') is Parameter.Type.INTEGER
    assert node.get_parameter_types(['level', 'use_sim_time']) == [
        Parameter.Type.INTEGER,
        Parameter.Type.BOOL,
    ]
    (described,) = node.describe_parameters(['level'])
    assert described == node.describe_parameter('level')
    assert (described.name, described.description, described.integer_range) == (
        'level',
        'how high',
        (0, 10, 1),
    )
    for ask in (node.get_parameter_type, node.describe_parameter):
        with pytest.raises(zros.ParameterNotDeclaredError, match="'nope' is not declared"):
            ask('nope')
    loose = zros_node('loose', allow_undeclared_parameters=True)
    assert loose.get_parameter_type('nope') is Parameter.Type.NOT_SET
    assert loose.describe_parameter('nope').type is Parameter.Type.NOT_SET
    # rclpy's handle: what add_ returns, remove_ takes
    refuse = node.add_on_set_parameters_callback(lambda changes: False)
    assert not node.set_parameters({'level': 4})[0]
    node.remove_on_set_parameters_callback(refuse)
    assert node.set_parameters({'level': 4})[0]
    with pytest.raises(ValueError):
        node.remove_on_set_parameters_callback(refuse)


def test_logger_level_and_timer_destroy_as_rclpys(zros_node: Callable[..., Node]) -> None:
    node = zros_node('leveled', log_level='warn')
    logger = node.get_logger()
    assert logger.get_effective_level() == 30
    logger.set_level('debug')
    assert logger.get_effective_level() == 10
    timer = node.create_timer(3600.0, lambda: None)
    timer.destroy()
    assert timer.is_canceled() and not node.destroy_timer(timer)


def test_get_parameters_and_by_prefix_return_rclpys_parameter_objects(
    zros_node: Callable[..., Node],
) -> None:
    node = zros_node('prefixed')
    node.declare_parameters('arm', [('speed', 1.5), ('joints', ['a', 'b'])])
    node.declare_parameter('armor', True)  # 'arm' is not its prefix: no dot after it
    assert node.get_parameters(['arm.speed', 'armor']) == [
        Parameter('arm.speed', Parameter.Type.DOUBLE, 1.5),
        Parameter('armor', Parameter.Type.BOOL, True),
    ]
    (speed,) = node.get_parameters(['arm.speed'])
    assert speed.type_ is Parameter.Type.DOUBLE and speed.value == 1.5
    assert node.get_parameters_by_prefix('arm') == {
        'speed': Parameter('arm.speed', value=1.5),
        'joints': Parameter('arm.joints', value=['a', 'b']),
    }
    assert set(node.get_parameters_by_prefix('')) >= {'arm.speed', 'armor', 'use_sim_time'}
    assert node.get_parameters_by_prefix('leg') == {}
    with pytest.raises(zros.ParameterNotDeclaredError, match="'nope' is not declared"):
        node.get_parameters(['arm.speed', 'nope'])
    with pytest.raises(TypeError, match='must be instances of type str'):
        node.get_parameters(['arm.speed', 1])  # type: ignore[list-item]
    with pytest.raises(TypeError, match=r"not the str 'arm\.speed'"):
        node.get_parameters('arm.speed')
    loose = zros_node('loose_params', allow_undeclared_parameters=True)
    assert loose.get_parameters(['nope']) == [Parameter('nope', Parameter.Type.NOT_SET)]
    # an empty array keeps its declared type (rclpy's Parameter takes [] for a double array)
    node.declare_parameter('gains', [], type=Parameter.Type.DOUBLE_ARRAY)
    assert node.get_parameters(['gains']) == [Parameter('gains', Parameter.Type.DOUBLE_ARRAY, [])]


def test_pre_and_post_set_parameters_callbacks_as_rclpys(zros_node: Callable[..., Node]) -> None:
    node = zros_node('staged')
    node.declare_parameter('mode', 'auto')
    node.declare_parameter('speed', 1.0)
    order: list[str] = []
    told: list[list[tuple[str, object]]] = []

    def add_speed(parameters: list[zros.params.Parameter]) -> list[zros.params.Parameter]:
        order.append('pre')
        extra = [Parameter('speed', value=0.0)] if parameters[0].value == 'manual' else []
        return [*parameters, *extra]

    def validate(parameters: list[zros.params.Parameter]) -> bool:
        order.append('on-set')
        return all(p.name != 'speed' or p.value >= 0.0 for p in parameters)  # type: ignore[operator]

    def after(parameters: list[zros.params.Parameter]) -> None:
        order.append('post')
        told.append([(p.name, p.value) for p in parameters])

    node.add_pre_set_parameters_callback(add_speed)
    node.add_on_set_parameters_callback(validate)
    node.add_post_set_parameters_callback(after)
    assert node.set_parameters([Parameter('mode', value='manual')])[0]
    assert order == ['pre', 'on-set', 'post']
    assert told == [[('mode', 'manual'), ('speed', 0.0)]]
    assert node.get_parameter('speed') == 0.0  # set along with mode, atomically
    # refused by on-set validation: post is not told
    told.clear()
    assert not node.set_parameters_atomically([Parameter('speed', value=-1.0)])
    assert told == [] and node.get_parameter('speed') == 0.0
    # post is told of declarations too (pre is not), as rclpy's
    order.clear()
    node.declare_parameter('gain', 2.0)
    assert order == ['on-set', 'post'] and told == [[('gain', 2.0)]]
    # a pre-set callback that empties the list refuses the set
    node.remove_pre_set_parameters_callback(add_speed)
    empty = node.add_pre_set_parameters_callback  # rclpy returns None: no handle
    assert empty(lambda parameters: []) is None
    result = node.set_parameters([Parameter('mode', value='auto')])[0]
    assert not result and 'parameter list cannot be empty' in result.reason
    assert node.get_parameter('mode') == 'manual'


def test_pre_and_post_set_callbacks_errors(zros_node: Callable[..., Node]) -> None:
    node = zros_node('staged_errors')
    node.declare_parameter('mode', 'auto')

    def broken(parameters: list[zros.params.Parameter]) -> list[zros.params.Parameter]:
        raise RuntimeError('no mode today')

    node.add_pre_set_parameters_callback(broken)
    result = node.set_parameters({'mode': 'manual'})[0]
    assert not result and "pre-set callback raised RuntimeError('no mode today')" in result.reason
    node.remove_pre_set_parameters_callback(broken)

    def not_a_list(parameters: list[zros.params.Parameter]) -> str:
        return 'mode'

    node.add_pre_set_parameters_callback(not_a_list)  # type: ignore[arg-type]
    result = node.set_parameters({'mode': 'manual'})[0]
    assert not result and 'returns a list of Parameters' in result.reason
    assert node.get_parameter('mode') == 'auto'
    with pytest.raises(ValueError):
        node.remove_pre_set_parameters_callback(broken)
    with pytest.raises(ValueError):
        node.remove_post_set_parameters_callback(print)
    with pytest.raises(TypeError, match='must be callable'):
        node.add_post_set_parameters_callback('after')  # type: ignore[arg-type]
    with pytest.raises(TypeError, match='must be callable'):
        node.add_pre_set_parameters_callback(None)  # type: ignore[arg-type]

    # a post-set callback's error reaches the caller, as rclpy's; the change has been made
    def failing(parameters: list[zros.params.Parameter]) -> None:
        raise RuntimeError('side effect failed')

    node.remove_pre_set_parameters_callback(not_a_list)  # type: ignore[arg-type]
    node.add_post_set_parameters_callback(failing)
    with pytest.raises(RuntimeError, match='side effect failed'):
        node.set_parameters({'mode': 'manual'})
    assert node.get_parameter('mode') == 'manual'


@pytest.mark.parametrize('zros_wire', ['bridge', 'rmw_zenoh'])
def test_publishers_and_subscriptions_info_by_topic(
    zros_node: Callable[..., Node], zros_wire: str
) -> None:
    owner = zros_node('owner', '/robot', start_parameter_services=False)
    observer = zros_node('observer', '/robot', remap=['scan:=/elsewhere'])
    owner.create_publisher('std_msgs/msg/String', 'scan', zros.QoS(7, zros.Reliability.RELIABLE))
    owner.create_subscription('std_msgs/msg/Int32', '/robot/cmd', None, 'sensor_data')

    def publishers() -> list[tuple[str, str]]:  # expanded, not remapped
        return [
            (i.node_name, i.node_namespace) for i in observer.get_publishers_info_by_topic('scan')
        ]

    # through a bridge the owner is told apart from the endpoint: wait for both
    assert wait_for(lambda: publishers() == [('owner', '/robot')], timeout=30.0)
    (publisher,) = observer.get_publishers_info_by_topic('scan')
    assert publisher.topic_type == 'std_msgs/msg/String'
    assert publisher.endpoint_type is TopicEndpointType.PUBLISHER
    assert int(publisher.endpoint_type) == 1  # rclpy's TopicEndpointTypeEnum value
    assert publisher.qos_profile is not None and publisher.qos_profile.depth == 7
    assert publisher.qos_profile.reliability is zros.Reliability.RELIABLE
    # a GID where the wire gives one (rmw_zenoh's 16 bytes), none through a bridge
    assert len(publisher.endpoint_gid) == (16 if zros_wire == 'rmw_zenoh' else 0)
    assert wait_for(lambda: observer.get_subscriptions_info_by_topic('cmd'), timeout=30.0)
    (subscription,) = observer.get_subscriptions_info_by_topic('/robot/cmd')
    assert subscription.endpoint_type is TopicEndpointType.SUBSCRIPTION
    assert subscription.topic_type == 'std_msgs/msg/Int32'
    assert subscription.qos_profile is not None
    assert subscription.qos_profile.reliability is zros.Reliability.BEST_EFFORT
    assert observer.get_publishers_info_by_topic('cmd') == []
    assert observer.get_subscriptions_info_by_topic('/nobody') == []
    with pytest.raises(zros.InvalidNameError):
        observer.get_publishers_info_by_topic('bad name')


def test_a_bridged_endpoint_has_rmws_unknown_node() -> None:
    bridged = Endpoint(EntityKind.SUBSCRIBER, 'abc', 'scan', 'std_msgs/msg/String', None, None)
    info = TopicEndpointInfo.from_endpoint(bridged)
    assert (info.node_name, info.node_namespace) == (
        '_NODE_NAME_UNKNOWN_',
        '_NODE_NAMESPACE_UNKNOWN_',
    )
    assert (info.endpoint_gid, info.qos_profile, info.topic_type_hash) == ([], None, '')
    assert info.endpoint_type is TopicEndpointType.SUBSCRIPTION


def test_create_node_and_executor_as_rclpys(zros_router: Router) -> None:
    made: list[Node] = []

    def create(name: str, **options: object) -> Node:
        made.append(zros.create_node(name, connect=zros_router.endpoint, **options))  # type: ignore[arg-type]
        return made[-1]

    try:
        node = create('made', namespace='/robot')
        assert isinstance(node, Node) and node.get_fully_qualified_name() == '/robot/made'
        assert create('root').get_namespace() == '/'
        # the node's own executor: the one rclpy's spin_until_future_complete may be given
        assert node.executor is node.context.executor
        future: concurrent.futures.Future[int] = concurrent.futures.Future()

        def answer() -> None:
            if not future.done():
                future.set_result(7)

        node.create_timer(0.01, answer)
        zros.spin_until_future_complete(node, future, executor=node.executor, timeout_sec=30.0)
        assert future.result() == 7
        node.executor = node.executor  # already its executor: nothing to do, as rclpy
        with pytest.raises(ValueError, match='runs on its own executor'):
            node.executor = create('other').executor
        with pytest.raises(ValueError, match='runs on its own executor'):
            node.executor = None
        with pytest.raises(TypeError, match='context'):
            create('ctx', context=object())
    finally:
        for each in made:
            each.destroy()
        zros.shutdown()  # closes the process's session that connect= opened
