"""How samples reach zros: a FIFO channel drained in batches on a thread per subscription, and
nodes whose callbacks run as messages arrive (``immediate_callbacks``)."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

import pytest

import zros
from zros.node import Node
from zros.testing import wait_for
from zros.transport import Transport, delivery


@pytest.fixture(params=['bridge', 'rmw_zenoh'])
def zros_wire(request: pytest.FixtureRequest) -> str:
    """The node tests of this module run on both wire schemes."""
    return str(request.param)


String = 'std_msgs/msg/String'


def delivery_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.endswith(delivery.THREAD_SUFFIX)]


def test_samples_queued_while_a_batch_is_handled_come_in_one_batch(
    zros_transport: Callable[..., Transport],
) -> None:
    session = zros_transport().session
    subscriber = session.declare_subscriber('delivery/test', delivery.channel())
    release = threading.Event()
    batches: list[list[bytes]] = []

    def on_samples(samples: list[Any]) -> None:
        batches.append([s.payload.to_bytes() for s in samples])
        release.wait(30)

    delivery.deliver(subscriber, on_samples, 'delivery/test')
    publisher = session.declare_publisher('delivery/test')
    publisher.put(b'first')
    assert wait_for(lambda: batches, 30)
    sent = [f'{i}'.encode() for i in range(200)]  # fewer than the channel holds
    for data in sent:
        publisher.put(data)
    release.set()
    assert wait_for(lambda: sum(map(len, batches)) == 201, 30)
    assert batches[0] == [b'first']
    assert [data for batch in batches[1:] for data in batch] == sent
    assert len(batches) < 10  # not one hand-over per sample
    subscriber.undeclare()
    session.close()


def test_a_raising_batch_callback_is_logged_and_delivery_goes_on(
    zros_transport: Callable[..., Transport], caplog: pytest.LogCaptureFixture
) -> None:
    session = zros_transport().session
    subscriber = session.declare_subscriber('delivery/raise', delivery.channel())
    got: list[bytes] = []

    def on_samples(samples: list[Any]) -> None:
        for sample in samples:
            data = sample.payload.to_bytes()
            if data == b'bad':
                raise ValueError('refused')
            got.append(data)

    thread = delivery.deliver(subscriber, on_samples, 'delivery/raise')
    publisher = session.declare_publisher('delivery/raise')
    with caplog.at_level(logging.ERROR, logger='zros'):
        publisher.put(b'bad')
        assert wait_for(lambda: 'delivering samples of delivery/raise failed' in caplog.text, 30)
        publisher.put(b'good')
        assert wait_for(lambda: got == [b'good'], 30)
    subscriber.undeclare()
    thread.join(30)
    assert not thread.is_alive()


def test_delivery_threads_end_with_their_subscriptions(zros_node: Callable[..., Node]) -> None:
    node = zros_node('listener')
    before = set(delivery_threads())
    subscriber = node.create_subscription(String, 'chatter', lambda _: None)
    mine = set(delivery_threads()) - before
    assert mine
    subscriber.close()
    assert wait_for(lambda: not any(t.is_alive() for t in mine), 30)
    node.create_subscription(String, 'chatter', lambda _: None)
    mine = set(delivery_threads()) - before
    node.transport.close()
    assert wait_for(lambda: not any(t.is_alive() for t in mine), 30)


def test_immediate_callbacks_run_as_messages_arrive_without_spin(
    zros_node: Callable[..., Node],
) -> None:
    talker, listener = zros_node('talker'), zros_node('listener', immediate_callbacks=True)
    got: list[str] = []
    threads: set[str] = set()

    def on_message(message: Any) -> None:
        got.append(message.data)
        threads.add(threading.current_thread().name)

    listener.create_subscription(String, 'chatter', on_message, qos='keep_all')
    publisher = talker.create_publisher(String, 'chatter', qos='keep_all')
    assert publisher.wait_for_subscribers(30)
    sent = [str(i) for i in range(2000)]
    for data in sent:
        publisher.write(zros.Message(String, data=data))
    assert wait_for(lambda: len(got) == len(sent), 30)  # nobody spins the listener
    assert got == sent
    assert all(name.endswith(delivery.THREAD_SUFFIX) for name in threads)


def test_immediate_keep_last_callbacks_get_the_newest_of_what_waited(
    zros_node: Callable[..., Node],
) -> None:
    """A callback that falls behind gets, of the messages that waited meanwhile, the newest
    ``depth`` (as a polled keep-last subscriber would), never the whole backlog."""
    talker, listener = zros_node('talker'), zros_node('listener', immediate_callbacks=True)
    release = threading.Event()
    got: list[int] = []

    def on_message(message: Any) -> None:
        got.append(int(message.data))
        release.wait(30)

    listener.create_subscription(String, 'chatter', on_message, qos=2)
    witness = listener.create_subscription(String, 'chatter', qos='keep_all')  # all arrived?
    publisher = talker.create_publisher(String, 'chatter', qos='keep_all')
    assert publisher.wait_for_subscribers(30)
    publisher.write(zros.Message(String, data='0'))
    assert wait_for(lambda: got == [0], 30)
    for i in range(1, 50):
        publisher.write(zros.Message(String, data=str(i)))
    assert wait_for(lambda: witness.received == 50, 30)
    release.set()
    assert wait_for(lambda: got[-1:] == [49], 30)
    assert got == [0, 48, 49]


def test_immediate_callbacks_answer_service_requests_without_spin(
    zros_node: Callable[..., Node],
) -> None:
    server, caller = zros_node('server', immediate_callbacks=True), zros_node('caller')
    add = 'example_interfaces/srv/AddTwoInts'
    server.create_service(add, 'add', lambda r: zros.get_type(add).Response(sum=r.a + r.b))
    client = caller.create_client(add, 'add', timeout=30)
    assert client.wait_for_service(30)
    assert client.call(a=2, b=3).sum == 5  # nobody spins the server
