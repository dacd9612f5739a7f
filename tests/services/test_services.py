"""Services between zros nodes: handlers, polling, async, errors, bytes on the wire."""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest

import zros
from tests.support.races import close_while_used
from tests.support.wire_support import reply_options, request_options
from zros.node import Node
from zros.services import (
    ServiceCallError,
    ServiceError,
    ServiceTimeoutError,
    ServiceUnavailableError,
)
from zros.services import client as client_module
from zros.services import errors as service_errors
from zros.services import server as server_module
from zros.testing import spinning, wait_for


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """Every test of this module that makes nodes runs on both wire schemes."""
    return str(request.param)


ADD = 'example_interfaces/srv/AddTwoInts'


def add(request: Any) -> Any:
    return zros.get_type(ADD).Response(sum=request.a + request.b)


def test_call_a_handler(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    server.create_service(ADD, 'add_two_ints', add)
    client = caller.create_client(ADD, 'add_two_ints')
    assert client.wait_for_service()
    with spinning(server):
        assert client.call(a=2, b=3).sum == 5
        assert client.call(client.Request(a=-7, b=2**40)).sum == 2**40 - 7
        assert client(a=1, b=1).sum == 2


def test_handlers_run_on_the_spinning_thread(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    threads: list[threading.Thread] = []

    def handler(request: Any, response: Any) -> Any:  # rclpy's form
        threads.append(threading.current_thread())
        response.sum = request.a + request.b
        return response

    server.create_service(ADD, 'add', handler)
    client = caller.create_client(ADD, 'add')
    assert client.wait_for_service()
    future = client.call_async(a=20, b=22)
    assert not future.done()  # nobody spins the server yet
    assert wait_for(lambda: server.spin_once(0.05) > 0)
    assert future.result(5).sum == 42
    assert threads == [threading.current_thread()]


def test_async_handlers(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')

    async def slow_add(request: Any) -> Any:
        await asyncio.sleep(0.01)
        return add(request)

    server.create_service(ADD, 'slow_add', slow_add)
    client = caller.create_client(ADD, 'slow_add')
    assert client.wait_for_service()
    with spinning(server):  # a plain spin: the node runs the coroutine on a loop of its own
        assert client.call(a=3, b=4).sum == 7

    async def on_one_loop() -> int:
        spin = asyncio.ensure_future(server.spin_async())
        try:
            results = await asyncio.gather(*(client.call_async(a=i, b=i) for i in range(10)))
            return sum(r.sum for r in results)
        finally:
            server.destroy()
            await spin

    assert asyncio.run(on_one_loop()) == sum(2 * i for i in range(10))


def test_polling_like_rosr(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    service = server.create_service(ADD, 'add')
    client = caller.create_client(ADD, 'add')
    assert client.wait_for_service()
    assert not service.has_request() and service.take_request() is None
    first = client.call_async(a=1, b=2)
    second = client.call_async(a=10, b=20)
    assert wait_for(lambda: service.received == 2)
    assert service.has_request()
    one, two = service.take_request(), service.take_request()
    assert (one.a, two.a) == (1, 10)
    service.respond(service.Response(sum=two.a + two.b), two)  # any order
    assert second.result(5).sum == 30 and not first.done()
    service.respond(service.Response(sum=one.a + one.b))  # the oldest taken
    assert first.result(5).sum == 3
    with pytest.raises(ServiceError, match='no request was taken'):
        service.respond(service.Response())
    third = client.call_async(a=5, b=5)
    request = service.wait_for_request(timeout=5)
    with pytest.raises(TypeError, match='answers with example_interfaces/srv/AddTwoInts_Response'):
        service.respond(zros.Message('std_msgs/msg/String'), request)
    service.respond(service.Response(sum=10), request)
    assert third.result(5).sum == 10
    with pytest.raises(ServiceError, match='not taken or already answered'):
        service.respond(service.Response(), request)
    assert service.wait_for_request(timeout=0.05) is None


def test_a_client_that_starts_before_its_server(zros_node: Callable[..., Node]) -> None:
    caller, server = zros_node('caller'), zros_node('server')
    client = caller.create_client(ADD, 'late')
    assert not client.service_is_ready()
    started = time.monotonic()
    assert not client.wait_for_service(timeout=0.2)
    assert time.monotonic() - started < 1
    with pytest.raises(ServiceUnavailableError, match='no server for /late'):
        client.call(a=1, b=2)
    threading.Timer(0.2, lambda: server.create_service(ADD, 'late', add)).start()
    assert client.wait_for_service(timeout=5)
    with spinning(server):
        assert client.call(a=1, b=2).sum == 3


def test_no_server_and_timeout_are_different_errors(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    started = time.monotonic()
    with pytest.raises(ServiceUnavailableError):
        caller.create_client(ADD, 'nobody').call(a=1, b=1)
    assert time.monotonic() - started < 1
    server.create_service(ADD, 'mute')  # polled, never answered
    client = caller.create_client(ADD, 'mute')
    assert client.wait_for_service()
    started = time.monotonic()
    with pytest.raises(ServiceTimeoutError, match=r'/mute did not reply within 0\.3 s'):
        client.call(a=1, b=1, timeout=0.3)
    assert 0.3 <= time.monotonic() - started < 2
    assert isinstance(ServiceTimeoutError('x'), TimeoutError)


def test_a_call_inside_a_callback_of_its_own_server_says_why_it_times_out(
    zros_node: Callable[..., Node],
) -> None:
    node = zros_node('selfcall')
    node.create_service(ADD, 'self_add', add)
    client = node.create_client(ADD, 'self_add')
    assert client.wait_for_service()
    errors: list[str] = []
    answers: list[int] = []

    def tick() -> None:
        timer.cancel()
        with pytest.raises(ServiceTimeoutError) as caught:
            client.call(a=1, b=2, timeout=0.3)
        errors.append(str(caught.value))
        # what the error advises works: the answer comes once this callback returns
        client.call_async(a=1, b=2).add_done_callback(lambda f: answers.append(f.result().sum))

    timer = node.create_timer(0.01, tick)
    assert wait_for(lambda: node.spin_once(0.05) >= 0 and answers == [3])
    assert errors == [
        '/self_add did not reply within 0.3 s; its server is node /selfcall, and this call '
        'waits inside a callback of that node, so the handler cannot run until the callback '
        'returns: use call_async() and take the response in a done callback, or serve it from '
        'a node spun on another thread (or made with immediate_callbacks=True)'
    ]


def test_a_call_to_a_server_of_this_process_nobody_spins_says_so(
    zros_node: Callable[..., Node],
) -> None:
    server, caller = zros_node('deaf'), zros_node('caller')
    server.create_service(ADD, '/deaf_add', add)
    client = caller.create_client(ADD, '/deaf_add')
    assert client.wait_for_service()
    with pytest.raises(
        ServiceTimeoutError,
        match=r'/deaf_add did not reply within 0\.3 s; its server, node /deaf of this process, '
        r'holds the request unanswered: nobody spins that node',
    ):
        client.call(a=1, b=2, timeout=0.3)
    with spinning(server):  # spun, it answers
        assert client.call(a=1, b=2).sum == 3


def test_a_handler_that_raises(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    server, caller = zros_node('server'), zros_node('caller')

    def fragile(request: Any) -> Any:
        if request.b == 0:
            raise ZeroDivisionError('b is zero')
        return add(request)

    server.create_service(ADD, 'fragile', fragile)
    client = caller.create_client(ADD, 'fragile')
    assert client.wait_for_service()
    with spinning(server), caplog.at_level(logging.ERROR, logger='zros'):
        with pytest.raises(ServiceCallError, match=r"raised ZeroDivisionError\('b is zero'\)"):
            client.call(a=1, b=0)
        assert client.call(a=1, b=1).sum == 2  # the server keeps working
    assert 'the handler of service /fragile raised' in caplog.text
    assert 'ZeroDivisionError: b is zero' in caplog.text  # with its traceback


def test_a_handler_that_returns_the_wrong_thing(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    server.create_service(ADD, 'sloppy', lambda request: request.a + request.b)
    client = caller.create_client(ADD, 'sloppy')
    assert client.wait_for_service()
    with spinning(server), pytest.raises(ServiceCallError, match='returned int, not'):
        client.call(a=1, b=2)


def test_a_request_that_does_not_decode(
    zros_node: Callable[..., Node], caplog: pytest.LogCaptureFixture
) -> None:
    server = zros_node('server')
    service = server.create_service(ADD, 'add', add)
    raw_node = zros_node('raw')
    assert raw_node.create_client(ADD, 'add').wait_for_service()  # the raw session sees it
    raw = raw_node.transport.session
    with spinning(server), caplog.at_level(logging.WARNING, logger='zros'):
        replies = list(
            raw.get(
                service.key,
                payload=b'\x00\x01\x00\x00\x02',
                timeout=5,
                **request_options(server),
            )
        )
        assert len(replies) == 1 and replies[0].err is not None
        text = replies[0].err.payload.to_string()
        assert text.startswith(service_errors.ERROR_PREFIX)
        assert 'does not decode as example_interfaces/srv/AddTwoInts_Request' in text
        assert 'does not decode' in caplog.text
        # still serving
        client = zros_node('caller').create_client(ADD, 'add')
        assert client.call(a=2, b=2).sum == 4
    assert service.failed == 1


def test_a_reply_that_does_not_decode(zros_node: Callable[..., Node]) -> None:
    rogue = zros_node('rogue').transport.session

    def reply_garbage(query: Any) -> None:
        with query:
            query.reply(query.key_expr, b'\x00\x01\x00\x00\x05', **reply_options(query))

    client = zros_node('caller').create_client(ADD, 'rogue')
    queryable = rogue.declare_queryable(client.key, reply_garbage, complete=True)
    try:
        assert client.wait_for_service()
        with pytest.raises(ServiceCallError, match=r'does not decode as .*AddTwoInts_Response'):
            client.call(a=1, b=2)
        with pytest.raises(ServiceCallError, match='does not decode'):
            client.call_async(a=1, b=2).result(5)
    finally:
        queryable.undeclare()


def test_a_foreign_error_reply(zros_node: Callable[..., Node]) -> None:
    rogue = zros_node('rogue').transport.session

    def refuse(query: Any) -> None:
        with query:
            query.reply_err('not today')

    client = zros_node('caller').create_client(ADD, 'refuse')
    queryable = rogue.declare_queryable(client.key, refuse, complete=True)
    try:
        assert client.wait_for_service()
        with pytest.raises(ServiceCallError, match='replied with an error: not today'):
            client.call(a=1, b=2)
    finally:
        queryable.undeclare()


def test_a_call_whose_server_went_away_without_answering_ends(
    zros_node: Callable[..., Node],
) -> None:
    """A server that disappears while holding a call (as a queryable undeclared while the
    query was on its way, which Zenoh does not always end) leaves no call waiting for its
    timeout (an action's result waits 30 days): the call ends as unavailable once no server
    matches for GONE_GRACE seconds."""
    rogue = zros_node('rogue').transport.session
    held: list[Any] = []
    client = zros_node('caller').create_client(ADD, 'vanishing')
    queryable = rogue.declare_queryable(client.key, held.append, complete=True)
    assert client.wait_for_service()
    future = client.call_async(a=1, b=2, timeout=3600)
    assert wait_for(lambda: len(held) == 1)
    queryable.undeclare()  # the query stays open: nobody answers or drops it
    began = time.monotonic()
    with pytest.raises(ServiceUnavailableError, match='went away before it replied'):
        future.result(30)
    assert time.monotonic() - began >= client_module.GONE_GRACE * 0.9
    held.clear()


def test_bytes_on_the_wire_match_the_bridge_spec(zros_node: Callable[..., Node]) -> None:
    """bridge-protocol.md §5: AddTwoInts a=2, b=3 and its reply 5, little-endian."""
    seen: list[bytes] = []
    raw_node = zros_node('raw')
    raw = raw_node.transport.session

    def capture(query: Any) -> None:
        seen.append(query.payload.to_bytes())
        with query:
            query.reply(
                query.key_expr, bytes.fromhex('000100000500000000000000'), **reply_options(query)
            )

    client = zros_node('caller').create_client(ADD, 'add_two_ints')
    queryable = raw.declare_queryable(client.key, capture, complete=True)
    try:
        assert client.wait_for_service()
        assert client.call(a=2, b=3).sum == 5
        assert seen == [bytes.fromhex('0001000002000000000000000300000000000000')]
    finally:
        queryable.undeclare()
    server = zros_node('server')
    server.create_service(ADD, 'add_two_ints', add)
    assert raw_node.create_client(ADD, 'add_two_ints').wait_for_service()
    with spinning(server):
        replies = list(raw.get(client.key, payload=seen[0], timeout=5, **request_options(server)))
    assert [r.ok.payload.to_bytes() for r in replies] == [bytes.fromhex('000100000500000000000000')]


def test_requests_without_fields(zros_node: Callable[..., Node]) -> None:
    """std_srvs/Empty: ROS sends the one-byte placeholder member, and so does zros."""
    server, caller = zros_node('server'), zros_node('caller')
    calls: list[Any] = []
    server.create_service('std_srvs/srv/Empty', 'reset', lambda r: calls.append(r) or r_empty())

    def r_empty() -> Any:
        return zros.get_type('std_srvs/srv/Empty').Response()

    client = caller.create_client('std_srvs/srv/Empty', 'reset')
    assert client.wait_for_service()
    with spinning(server):
        client.call()
        replies = list(
            caller.transport.session.get(
                client.key, payload=b'\x00\x01\x00\x00\x00', **request_options(caller)
            )
        )
    assert len(calls) == 2 and replies[0].ok is not None
    assert replies[0].ok.payload.to_bytes() == b'\x00\x01\x00\x00\x00'


def test_services_in_the_graph(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server', '/robot'), zros_node('monitor')
    service = server.create_service(ADD, 'add', add)
    client = server.create_client('std_srvs/srv/Trigger', '~/reset')
    graph = caller.graph
    assert graph.wait_until(lambda: '/robot/add' in graph.services(), timeout=5)
    assert graph.services()['/robot/add'] == [ADD]

    def owned() -> set[tuple[str, str]]:
        return {(e.kind.value, e.key) for e in graph.node_endpoints('/robot/server')}

    key = server.scheme.key
    expected = {('SS', key('/robot/add')), ('SC', key('/robot/server/reset'))}
    assert graph.wait_until(lambda: expected <= owned(), timeout=5), owned()
    service.close()
    client.close()
    assert graph.wait_until(lambda: '/robot/add' not in graph.services(), timeout=5)


def test_closing_a_server_answers_what_it_holds(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    service = server.create_service(ADD, 'add')
    client = caller.create_client(ADD, 'add')
    assert client.wait_for_service()
    waiting, taken = client.call_async(a=1, b=1), client.call_async(a=2, b=2)
    assert wait_for(lambda: service.received == 2)
    service.take_request()
    service.close()
    for future in (waiting, taken):
        with pytest.raises(ServiceCallError, match='the service /add closed'):
            future.result(5)
    assert wait_for(lambda: not client.service_is_ready())


def test_closing_a_service_of_a_never_spun_node_drops_its_pending_work(
    zros_node: Callable[..., Node],
) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    service = server.create_service(ADD, 'add', add)
    client = caller.create_client(ADD, 'add')
    assert client.wait_for_service()
    future = client.call_async(a=1, b=1)
    assert wait_for(lambda: service.received == 1)
    pending = server.context.executor._ready
    assert len(pending) == 1  # its callback waits for a spin that never comes
    service.close()
    with pytest.raises(ServiceCallError, match='the service /add closed'):
        future.result(5)
    assert len(pending) == 0  # nor does it hold the service any longer


def test_a_flooded_server_refuses_beyond_its_limit(
    zros_node: Callable[..., Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(server_module, 'MAX_PENDING', 3)
    server, caller = zros_node('server'), zros_node('caller')
    service = server.create_service(ADD, 'add')
    client = caller.create_client(ADD, 'add')
    assert client.wait_for_service()
    futures = [client.call_async(a=i, b=0, timeout=5) for i in range(5)]
    assert wait_for(lambda: sum(f.done() for f in futures) == 2)
    for future in futures[3:]:
        with pytest.raises(ServiceCallError, match='holds 3 unanswered requests'):
            future.result(0)
    assert service.received == 3


def test_a_late_reply_warns_about_the_bridge_timeout(
    zros_node: Callable[..., Node],
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    monkeypatch.setattr(server_module, 'BRIDGE_TIMEOUT', -1.0)  # every reply counts as late
    server, caller = zros_node('server'), zros_node('caller')
    service = server.create_service(ADD, 'slow')
    client = caller.create_client(ADD, 'slow')
    assert client.wait_for_service()
    future = client.call_async(a=1, b=1)
    request = service.wait_for_request(timeout=5)
    with caplog.at_level(logging.WARNING, logger='zros'):
        service.respond(service.Response(sum=2), request)
    assert future.result(5).sum == 2
    assert 'answered after' in caplog.text and 'queries_timeout' in caplog.text


def test_call_async_callbacks_run_where_the_node_spins(zros_node: Callable[..., Node]) -> None:
    server, caller = zros_node('server'), zros_node('caller')
    server.create_service(ADD, 'add', add)
    client = caller.create_client(ADD, 'add')
    assert client.wait_for_service()
    seen: list[tuple[int, threading.Thread]] = []
    with spinning(server):
        client.call_async(
            a=4, b=4, callback=lambda f: seen.append((f.result().sum, threading.current_thread()))
        ).result(5)
        assert seen == []  # the caller has not spun yet
        assert wait_for(lambda: caller.spin_once(0.05) > 0)
    assert seen == [(8, threading.current_thread())]


def test_mistakes_are_named(zros_node: Callable[..., Node]) -> None:
    node = zros_node('node')
    with pytest.raises(TypeError, match='std_msgs/msg/String is not a service type'):
        node.create_service('std_msgs/msg/String', 'x', add)
    fibonacci = node.registry.get_type('example_interfaces/action/Fibonacci')
    with pytest.raises(TypeError, match='action/Fibonacci> is not a service type'):
        node.create_client(fibonacci, 'x')  # type: ignore[arg-type]  # a type, of another kind
    with pytest.raises(zros.InvalidNameError):
        node.create_client(ADD, 'bad name')
    client = node.create_client(ADD, 'add')
    with pytest.raises(TypeError, match='takes example_interfaces/srv/AddTwoInts_Request'):
        client.call(zros.Message('std_msgs/msg/String'))
    with pytest.raises(TypeError, match='not both'):
        client.call(client.Request(), a=1)
    client.close()
    with pytest.raises(ServiceError, match='was closed'):
        client.call(a=1, b=2)


def test_the_default_node_offers_rosr_shaped_classes(zros_router: Any) -> None:
    zros.init('rosr', connect=zros_router.endpoint, handle_sigint=False)
    try:
        server = zros.Service('/add', ADD, add)
        client = zros.Client('/add', ADD)
        assert client.wait_for_service()
        future = client.call_async(a=40, b=2)
        assert wait_for(lambda: zros.spin_once(0.05) > 0)
        assert future.result(5).sum == 42
        assert server.node is client.node is zros.default_node()
    finally:
        zros.shutdown()


def test_closing_a_client_while_another_thread_asks_for_its_server(
    zros_node: Callable[..., Node],
) -> None:
    """close() waits for a readiness check in progress on another thread (zenoh-python refuses
    to undeclare a querier in use); a closed client is never ready."""
    node = zros_node('caller')
    for _ in range(30):
        client = node.create_client(ADD, 'race')
        ready_after_close, errors = close_while_used(client, client.service_is_ready)
        assert errors == [] and ready_after_close is False
