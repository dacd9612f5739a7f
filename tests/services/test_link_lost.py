"""A call or goal waiting when the session loses its router ends at once, saying so."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

import zros
from tests.support.router_process import (
    CALL_TIMEOUT,
    FIB,
    TRIGGER,
    Rig,
    free_endpoint,
    rig_running,
)
from zros.testing import wait_for
from zros.transport import Transport, TransportConfig


@pytest.fixture
def rig() -> Iterator[Rig]:
    with rig_running() as running:
        yield running


def assert_link_lost(error: BaseException, rig: Rig) -> None:
    assert isinstance(error, zros.LinkLostError)
    assert isinstance(error, zros.ServiceUnavailableError)  # what callers already catch
    assert f'the link to the router at {rig.router.endpoint} was lost' in str(error)
    assert 'zros reconnects when the router is back' in str(error)
    assert 'wait_for_service' not in str(error)


def test_a_call_waiting_when_the_router_dies_fails_at_once(rig: Rig) -> None:
    client = rig.caller.create_client(TRIGGER, 'slow', timeout=CALL_TIMEOUT)
    assert client.wait_for_service(10)
    rig.kill_router_when_held()
    with pytest.raises(zros.LinkLostError) as raised:
        client.call()
    waited = time.monotonic() - rig.killed
    assert_link_lost(raised.value, rig)
    assert waited < CALL_TIMEOUT / 3, f'{waited:.1f} s from the kill to the error'
    # and a call made while the link is down fails at once, without a query
    started = time.monotonic()
    with pytest.raises(zros.LinkLostError, match='cannot call /slow') as again:
        client.call()
    assert time.monotonic() - started < 1.0
    assert_link_lost(again.value, rig)
    with pytest.raises(zros.LinkLostError):
        client.call_async()


def test_an_async_call_waiting_when_the_router_dies_fails_at_once(rig: Rig) -> None:
    client = rig.caller.create_client(TRIGGER, 'slow', timeout=CALL_TIMEOUT)
    assert client.wait_for_service(10)
    rig.kill_router_when_held()
    future = client.call_async()
    with pytest.raises(zros.LinkLostError) as raised:
        future.result(CALL_TIMEOUT)
    assert time.monotonic() - rig.killed < CALL_TIMEOUT / 3
    assert_link_lost(raised.value, rig)


def test_a_goal_waiting_for_its_result_when_the_router_dies_fails_at_once(rig: Rig) -> None:
    client = rig.caller.create_action_client(FIB, 'fib')
    assert client.wait_for_server(10)
    handle = client.send_goal(order=3, timeout=CALL_TIMEOUT)
    assert handle.accepted
    rig.kill_router_when_held()  # once accepted: its result is what waits
    with pytest.raises(zros.ActionError, match='no result for goal') as raised:
        handle.result(CALL_TIMEOUT)
    assert time.monotonic() - rig.killed < CALL_TIMEOUT / 3
    assert f'the link to the router at {rig.router.endpoint} was lost' in str(raised.value)
    # a goal sent while the link is down is refused at once
    assert wait_for(lambda: not rig.transports[1].connected, timeout=10)
    started = time.monotonic()
    with pytest.raises(zros.LinkLostError, match='cannot call /fib/_action/send_goal'):
        client.send_goal(order=3, timeout=CALL_TIMEOUT)
    assert time.monotonic() - started < 1.0


def test_calls_work_again_once_the_router_is_back(rig: Rig) -> None:
    client = rig.caller.create_client(TRIGGER, 'slow', timeout=CALL_TIMEOUT)
    assert client.wait_for_service(10)
    rig.router.kill()
    assert wait_for(lambda: not rig.transports[1].connected, timeout=10)
    with pytest.raises(zros.LinkLostError):
        client.call()
    rig.release.set()  # the server answers at once from now on
    rig.router.start()
    assert client.wait_for_service(CALL_TIMEOUT)
    assert client.call().success is False  # Trigger's default response


def test_a_call_of_a_session_that_never_reached_its_router_fails_at_once() -> None:
    endpoint = free_endpoint()  # closed: nothing listens there
    config = TransportConfig.create(
        connect=endpoint, mode='peer', listen=[], wait_for_router=False, shared_memory=False
    )
    with Transport(config) as transport:
        node = zros.Node('alone', transport=transport)
        client = node.create_client(TRIGGER, 'slow', timeout=CALL_TIMEOUT)
        started = time.monotonic()
        with pytest.raises(zros.LinkLostError) as raised:
            client.call()
        assert time.monotonic() - started < 1.0
        assert str(raised.value) == (
            f'cannot call /slow: the router at {endpoint} has not been reached yet '
            '(Zenoh keeps trying)'
        )


def test_a_goal_whose_result_cannot_be_asked_fails_with_the_reason(
    rig: Rig, monkeypatch: pytest.MonkeyPatch
) -> None:
    client = rig.caller.create_action_client(FIB, 'fib')
    assert client.wait_for_server(10)

    def link_lost(*args: object, **kwargs: object) -> None:
        raise zros.LinkLostError('cannot call /fib/_action/get_result: the link was lost')

    # the link dropped between the goal's acceptance and the result's request
    monkeypatch.setattr(client._get_result, 'call_async', link_lost)
    rig.release.set()
    handle = client.send_goal(order=3, timeout=CALL_TIMEOUT)
    assert handle.accepted
    with pytest.raises(zros.ActionError, match=r'no result for goal .*: cannot call /fib/_action'):
        handle.result(CALL_TIMEOUT)
