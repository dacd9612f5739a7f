"""Signal: the wake-up every blocking call of zros sleeps on (one waiter lock per thread)."""

from __future__ import annotations

import threading
import time

import pytest

from zros.runtime.signal import Signal
from zros.testing import wait_for

TIMEOUT = 30.0


@pytest.mark.parametrize('on_main_thread', [True, False], ids=['main thread', 'other thread'])
def test_a_wait_ends_when_notified(on_main_thread: bool) -> None:
    signal = Signal()
    done = threading.Event()

    def notify_once_waiting() -> None:
        assert wait_for(lambda: bool(signal.waiters), TIMEOUT)
        signal.notify()

    def wait() -> None:
        signal.wait(lambda: False, TIMEOUT)
        done.set()

    if on_main_thread:
        threading.Thread(target=notify_once_waiting).start()
        start = time.monotonic()
        wait()
    else:
        waiter = threading.Thread(target=wait)
        start = time.monotonic()
        waiter.start()
        notify_once_waiting()
        waiter.join(TIMEOUT)
    assert done.is_set()
    assert time.monotonic() - start < TIMEOUT / 2
    assert not signal.waiters


def test_every_waiting_thread_wakes() -> None:
    signal = Signal()
    woken: list[int] = []

    def wait(n: int) -> None:
        signal.wait(lambda: False, TIMEOUT)
        woken.append(n)

    threads = [threading.Thread(target=wait, args=(n,)) for n in range(4)]
    for thread in threads:
        thread.start()
    assert wait_for(lambda: len(signal.waiters) == 4, TIMEOUT)
    signal.notify()
    for thread in threads:
        thread.join(TIMEOUT)
    assert sorted(woken) == [0, 1, 2, 3]


def test_a_wait_runs_out_and_leaves_nothing_registered() -> None:
    signal = Signal()
    start = time.monotonic()
    signal.wait(lambda: False, 0.05)
    assert time.monotonic() - start >= 0.05
    assert not signal.waiters
    assert signal.wait_for(lambda: False, 0.05) is False


def test_a_notify_never_ends_the_threads_next_wait() -> None:
    """Each thread sleeps on one lock, reused from wait to wait: a notify that takes the lock
    of a wait just as it runs out must not release it into the thread's next wait."""
    busy, quiet = Signal(), Signal()
    stop = threading.Event()
    short: list[float] = []

    def notifier() -> None:
        while not stop.is_set():
            busy.notify()

    def waiter() -> None:
        for _ in range(150):
            busy.wait(lambda: False, 0.0005)  # ends by a notify or runs out, at random
            start = time.monotonic()
            quiet.wait(lambda: False, 0.01)  # nobody notifies it
            if time.monotonic() - start < 0.01:
                short.append(time.monotonic() - start)

    threads = [threading.Thread(target=notifier), threading.Thread(target=waiter)]
    for thread in threads:
        thread.start()
    threads[1].join(TIMEOUT)
    stop.set()
    threads[0].join(TIMEOUT)
    assert not short


def test_waits_on_one_thread_reuse_one_lock() -> None:
    signal = Signal()
    locks = set()

    def record() -> bool:
        locks.add(id(signal.waiters[0]))
        return True

    for _ in range(100):
        signal.wait(record, 1.0)
    assert len(locks) == 1


@pytest.mark.parametrize('on_main_thread', [True, False], ids=['main thread', 'other thread'])
def test_a_wait_whose_notify_was_cut_short_ends(on_main_thread: bool) -> None:
    """A notify takes the waiter's lock out of the list, then releases it; an exception between
    the two (a second Ctrl-C on the notifying thread) loses the release. The wait, even one
    without a timeout, ends once it sees its lock was taken, within a few seconds (on the main
    thread the test waits 20 s at most, so that a regression fails instead of hanging)."""
    signal = Signal()
    lengths: list[float] = []

    def wait() -> None:
        start = time.monotonic()
        signal.wait(lambda: False, 20.0 if on_main_thread else None)
        lengths.append(time.monotonic() - start)

    def lose_the_release() -> None:
        assert wait_for(lambda: bool(signal.waiters), TIMEOUT)
        signal.waiters.pop()  # what notify does first; its release never comes

    if on_main_thread:
        threading.Thread(target=lose_the_release).start()
        wait()
    else:
        waiter = threading.Thread(target=wait, daemon=True)
        waiter.start()
        lose_the_release()
        waiter.join(TIMEOUT)
    assert lengths and lengths[0] < 5.0
    assert not signal.waiters
