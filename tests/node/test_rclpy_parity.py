"""rclpy code ports as docs/mapping.md says: rclpy's node methods, Node subclasses, spinning that
Ctrl-C ends cleanly, and ``zros.init(args=...)`` adding no node of its own to the graph."""

from __future__ import annotations

import signal
from collections.abc import Callable, Iterator

import pytest

import zros
from tests.support.processes import Script, sleeping
from zros.node import Node
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
