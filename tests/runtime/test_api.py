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
