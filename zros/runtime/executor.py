"""The callback queue of one node, and the ways to run it (spin, spin once, on an asyncio loop).

Zenoh delivers samples and queries on its own threads; entities queue their :class:`Work`
here and the executor runs it, with due timers, on whichever thread spins the node. Async
callbacks run on the loop of :meth:`Executor.spin_async`, else on an event-loop thread the
executor starts on first use.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import contextlib
import logging
import threading
import time
import weakref
from collections.abc import Callable, Coroutine
from typing import Protocol, TypeVar

from zros.runtime.clock import Clock
from zros.runtime.signal import Signal, interrupt, interrupt_flag

T = TypeVar('T')
_log = logging.getLogger('zros')
_executors: weakref.WeakSet[Executor] = weakref.WeakSet()


def wake_all() -> None:
    """Make every node's waiting spin return (after Ctrl-C)."""
    for executor in list(_executors):
        executor.wake()


def shut_down_on_ctrl_c() -> None:
    """What the first Ctrl-C does under ``zros.init``'s handler, for a spin that Python's own
    KeyboardInterrupt ended (no ``zros.init``): ``ok()`` turns false and every wait ends."""
    interrupt()
    wake_all()


class Work:
    """Something an entity has to do on the spinning thread: ``run()`` returns how many
    callbacks ran. Queued at most once until it runs."""

    __slots__ = ('run', 'scheduled')

    def __init__(self, run: Callable[[], int], scheduled: bool = False) -> None:
        self.run = run
        self.scheduled = scheduled


class TimerLike(Protocol):
    """What the executor needs of a timer."""

    @property
    def cancelled(self) -> bool:
        """Whether the timer was cancelled."""

    def seconds_until_due(self) -> float | None:
        """Wall seconds until due (<= 0: now; None: when the sim clock moves)."""

    def fire(self) -> None:
        """Run the callback and count the next period."""

    def cancel(self) -> None:
        """Stop the timer for good."""


class Executor:
    """The callback queue of one node: work from its entities (unread messages, requests,
    queued calls), and timers.

    ``immediate``: the work of subscribers and services runs at once on the thread that
    delivers it (a subscription's delivery thread, a service's Zenoh thread) instead of
    waiting for a spin: one thread hand-over less per message, but callbacks of different
    entities may run at the same time, and one that blocks holds up its entity's deliveries.
    Timers and queued calls still run where the node spins.
    """

    def __init__(self, name: str = 'zros', *, immediate: bool = False) -> None:
        self.name = name  #: names the event-loop thread
        self.immediate = immediate
        self._ready: collections.deque[Work] = collections.deque()
        self._signal = Signal()
        self._timers: list[TimerLike] = []
        self._async_wakers: list[Callable[[], None]] = []
        self._woken = False  #: wake() was called: a waiting run_once returns even with no work
        self.stopped = False
        #: the thread running this executor's callbacks now (None: none), for diagnostics
        self.callback_thread: int | None = None
        self._spin_loop: asyncio.AbstractEventLoop | None = None  #: the loop of spin_async
        self._own_loop: asyncio.AbstractEventLoop | None = None  #: async callbacks otherwise
        self._loop_lock = threading.Lock()
        _executors.add(self)

    # --- from any thread (Zenoh's included: keep it cheap) ---------------------------------

    def schedule(self, work: Work) -> None:
        """Queue ``work`` unless already queued (run it now if ``immediate``)."""
        if self.immediate:
            if not self.stopped:
                work.run()
            return
        self.queue(work)

    def queue(self, work: Work) -> None:
        """Queue ``work`` unless already queued, to run where the node spins (also when
        ``immediate``, as :meth:`call_soon`'s functions do)."""
        if not work.scheduled:
            work.scheduled = True
            self._ready.append(work)
            if self._signal.waiters:  # _wake, inlined: once per delivered batch
                self._signal.notify()
            for waker in self._async_wakers:
                waker()

    def cancel(self, work: Work) -> None:
        """Drop ``work`` for good (its entity closed): out of the queue, never queued again,
        so a node that does not spin frees what it holds at once."""
        work.scheduled = True  # schedule() skips it from now on
        with contextlib.suppress(ValueError):  # not queued
            self._ready.remove(work)

    def call_soon(self, function: Callable[[], object]) -> None:
        """Run ``function()`` on the spinning thread (thread-safe)."""

        def run() -> int:
            try:
                function()
            except Exception:  # a user callback: logged, the executor goes on
                _log.exception('callback %r raised', function)
            return 1

        self._ready.append(Work(run, scheduled=True))
        self._wake()

    def _wake(self) -> None:
        if self._signal.waiters:
            self._signal.notify()
        for waker in self._async_wakers:
            waker()

    def wake(self) -> None:
        """Make a waiting ``run_once`` return (shutdown, Ctrl-C, the sim clock moved)."""
        self._woken = True
        self._signal.notify()
        for waker in self._async_wakers:
            waker()

    def ok(self) -> bool:
        """True until the executor stops or the process got Ctrl-C."""
        return not (self.stopped or interrupt_flag.value)

    # --- timers ------------------------------------------------------------------------------

    def add_timer(self, timer: TimerLike) -> None:
        """Run ``timer`` when it is due."""
        self._timers.append(timer)
        self.wake()

    def remove_timer(self, timer: TimerLike) -> None:
        """Stop running ``timer``."""
        if timer in self._timers:
            self._timers.remove(timer)

    def _run_timers(self) -> int:
        done = 0
        for timer in list(self._timers):
            wait = timer.seconds_until_due()
            if wait is not None and wait <= 0 and not timer.cancelled:
                timer.fire()
                done += 1
        return done

    def next_timer(self) -> float | None:
        """Seconds until the next timer is due (None: none, or when the sim clock moves)."""
        waits = [w for w in (t.seconds_until_due() for t in self._timers) if w is not None]
        return min(waits, default=None)

    # --- running -----------------------------------------------------------------------------

    def _has_work(self) -> bool:
        return bool(self._ready) or self._woken or self.stopped or interrupt_flag.value

    def _run_due(self) -> int:
        """Run the ready work, then the due timers; returns how many callbacks ran."""
        ready = self._ready
        done = 0
        outer, self.callback_thread = self.callback_thread, threading.get_ident()
        try:
            while ready:
                work = ready.popleft()
                work.scheduled = False
                done += work.run()
            if self._timers:
                done += self._run_timers()
        finally:
            self.callback_thread = outer
        return done

    def run_once(self, timeout: float | None) -> int:
        """Run what is due; wait up to ``timeout`` seconds (None: forever) for something to do."""
        done = self._run_due() if self._ready or self._timers else 0
        if done or (timeout is not None and timeout <= 0):
            return done
        deadline = None if timeout is None else time.monotonic() + timeout
        while not (self.stopped or interrupt_flag.value):
            wait: float | None = None if deadline is None else deadline - time.monotonic()
            if self._timers:
                next_timer = self.next_timer()
                if next_timer is not None:
                    wait = next_timer if wait is None else min(wait, next_timer)
            if wait is None or wait > 0:
                self._signal.wait(self._has_work, wait, interruptible=True)
            done = self._run_due()
            woken, self._woken = self._woken, False
            if done or woken or (deadline is not None and time.monotonic() >= deadline):
                return done
        return 0

    def spin(self, timeout: float | None = None) -> None:
        """Run callbacks and timers until not ``ok()`` (or ``timeout`` seconds)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not (self.stopped or interrupt_flag.value):  # ok(), inlined: once per message
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                return
            self.run_once(remaining)

    def spin_until(self, deadline: float) -> None:
        """Run callbacks and timers until ``time.monotonic()`` reaches ``deadline``."""
        while self.ok():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return
            self.run_once(remaining)

    def spin_until_future_complete(
        self, future: concurrent.futures.Future[T], timeout_sec: float | None = None
    ) -> None:
        """Run callbacks and timers until ``future`` is done, ``timeout_sec`` seconds pass (None
        or negative: no limit; 0: one run of what is due) or not ``ok()``, as rclpy's
        executor does."""
        if future.done():
            return  # no done callback: its wake-up would end the next spin_once early
        future.add_done_callback(lambda _: self.wake())
        forever = timeout_sec is None or timeout_sec < 0
        deadline = time.monotonic() + (0.0 if timeout_sec is None else timeout_sec)
        while self.ok() and not future.done():
            remaining = None if forever else deadline - time.monotonic()
            self.run_once(remaining)
            if remaining is not None and time.monotonic() >= deadline:
                return

    def spin_until_clock(self, clock: Clock, deadline: int) -> None:
        """Run callbacks and timers until the timer base of ``clock`` reaches ``deadline``."""
        while self.ok():
            remaining = clock.seconds_until(deadline)
            if remaining is not None and remaining <= 0:
                return
            self.run_once(remaining)

    async def spin_async(self) -> None:
        """Run callbacks and timers on the running asyncio loop until not ``ok()``."""
        loop = asyncio.get_running_loop()
        event = asyncio.Event()

        def waker() -> None:
            loop.call_soon_threadsafe(event.set)

        self._async_wakers.append(waker)
        self._spin_loop = loop
        try:
            while self.ok():
                event.clear()
                if self.run_once(0):
                    await asyncio.sleep(0)
                    continue
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(event.wait(), self.next_timer())
        finally:
            self._spin_loop = None
            self._async_wakers.remove(waker)

    def run_coroutine(self, coroutine: Coroutine[object, None, T]) -> concurrent.futures.Future[T]:
        """Run an async callback: on the loop of :meth:`spin_async` while one spins, else on
        an event loop thread of the executor's own (started on first use)."""
        loop = self._spin_loop
        if loop is None or not loop.is_running():
            with self._loop_lock:
                loop = self._own_loop
                if loop is None:
                    if self.stopped:
                        raise RuntimeError(f'node {self.name} was destroyed')
                    loop = self._own_loop = asyncio.new_event_loop()
                    threading.Thread(
                        target=loop.run_forever, name=f'zros async {self.name}', daemon=True
                    ).start()
        return asyncio.run_coroutine_threadsafe(coroutine, loop)

    def _stop_own_loop(self) -> None:
        with self._loop_lock:
            loop, self._own_loop = self._own_loop, None
        if loop is None:
            return

        def stop() -> None:
            for task in asyncio.all_tasks(loop):
                task.cancel()
            loop.call_soon(loop.stop)

        with contextlib.suppress(RuntimeError):  # already closed
            loop.call_soon_threadsafe(stop)

    def stop(self) -> None:
        """Stop for good: no more spinning, timers cancelled, the own event loop ended."""
        self.stopped = True
        for timer in list(self._timers):
            timer.cancel()
        self._stop_own_loop()
        self.wake()
