"""A client's bounded outbox: the oldest items drop, a burst of drops is told once."""

from __future__ import annotations

import threading

import pytest

from zros.gateway.common.send_queue import SendQueue

TIMEOUT = 10.0


def test_a_send_queue_drops_its_oldest_items_and_tells_once_per_burst() -> None:
    reports: list[int] = []
    outbox: SendQueue[str] = SendQueue(max_items=4, max_bytes=100, on_drop=reports.append)
    for i in range(6):
        outbox.put(f'm{i}', 10)
    assert len(outbox) == 4 and outbox.dropped == 2
    assert reports == [1]  # told at the start of the burst, not per item
    assert [outbox.get(0) for _ in range(4)] == ['m2', 'm3', 'm4', 'm5']
    outbox.put('small', 10)
    outbox.put('huge', 95)  # over the byte bound with 'small': the oldest goes
    assert outbox.dropped == 3 and reports == [1, 3]
    assert outbox.size == 95
    assert outbox.get(0) == 'huge'
    assert outbox.get(0.01) is None


def test_a_send_queue_wakes_a_waiting_reader_and_closes() -> None:
    outbox: SendQueue[int] = SendQueue()
    got: list[int | None] = []
    reader = threading.Thread(target=lambda: got.append(outbox.get(TIMEOUT)))
    reader.start()
    outbox.put(7, 1)
    reader.join(TIMEOUT)
    assert got == [7]
    closing = threading.Thread(target=lambda: got.append(outbox.get(TIMEOUT)))
    closing.start()
    outbox.close()
    closing.join(TIMEOUT)
    assert got == [7, None]
    outbox.put(8, 1)  # ignored once closed
    assert len(outbox) == 0
    with pytest.raises(ValueError, match='at least one'):
        SendQueue(max_items=0)


def test_a_failing_drop_callback_is_logged(caplog: pytest.LogCaptureFixture) -> None:
    def broken(count: int) -> None:
        raise RuntimeError('nope')

    outbox: SendQueue[int] = SendQueue(max_items=1, on_drop=broken)
    outbox.put(1, 1)
    outbox.put(2, 1)
    assert outbox.get(0) == 2
    assert 'the drop callback' in caplog.text
