"""A wake-up primitive lighter than ``threading.Condition``, and Ctrl-C for blocking calls.

A Condition wakes its waiter while the notifier still holds the condition's lock, so the woken
thread blocks again at once to reacquire it: two scheduler round trips per wake-up. Here each
waiter sleeps on a lock of its own that the notifier releases, and re-checks its predicate after
registering, so no wake-up is lost.

The first Ctrl-C after ``zros.init`` calls :func:`interrupt`: every wait of the public API
(:meth:`Signal.wait_for`, :func:`sleep`) ends at once, on whichever thread it sleeps, and any
started later ends at once too, until :func:`clear_interrupt` (the next ``zros.init``).
"""

from __future__ import annotations

import _thread
import contextlib
import logging
import threading
import time
from collections.abc import Callable, Iterator


class _Flag:
    """A flag without a lock (``threading.Event`` takes one): the SIGINT handler sets it on the
    main thread between two bytecodes, possibly while that thread is clearing it. Read as an
    attribute, not through a method: waits test it on every wake-up."""

    __slots__ = ('value',)

    def __init__(self) -> None:
        self.value = False


#: what :func:`interrupted` returns, as ``interrupt_flag.value``: loops that run once per
#: message (the executor's) read it there, saving a call; only this module sets it
interrupt_flag = _Flag()
#: the locks of the interruptible waits sleeping now
_sleeping: set[_thread.LockType] = set()
_listeners: list[Callable[[], object]] = []
_listeners_lock = threading.Lock()
#: released to make the listener thread run the listeners (a signal handler must not: it runs
#: between two bytecodes of the main thread, which may hold a lock a listener takes)
_listeners_due = _thread.allocate_lock()
_listeners_due.acquire()
_listener_thread: threading.Thread | None = None


def interrupted() -> bool:
    """Whether Ctrl-C ended zros's blocking calls (until the next ``zros.init``)."""
    return interrupt_flag.value


def interrupt() -> None:
    """End every interruptible wait now, and make later ones end at once (Ctrl-C).

    Safe in a signal handler: it only releases locks; the listeners run on a thread of their
    own once :func:`start_listener_thread` started it, else right here.
    """
    interrupt_flag.value = True
    for lock in tuple(_sleeping):
        with contextlib.suppress(RuntimeError):  # released already
            lock.release()
    if _listener_thread is None:
        _run_listeners()
    else:
        with contextlib.suppress(RuntimeError):  # the listeners are due already
            _listeners_due.release()


def _run_listeners() -> None:
    with _listeners_lock:
        listeners = list(_listeners)
    for listener in listeners:
        try:
            listener()
        except BaseException:  # a future's callbacks may re-raise the KeyboardInterrupt
            logging.getLogger('zros').debug('interrupt listener %r raised', listener, exc_info=True)


def _listener_loop() -> None:
    while True:
        _listeners_due.acquire()
        _run_listeners()


def start_listener_thread() -> None:
    """Run interrupt listeners on a thread of their own (``zros.init`` starts it before it
    installs its SIGINT handler)."""
    global _listener_thread  # noqa: PLW0603
    with _listeners_lock:
        if _listener_thread is None:
            _listener_thread = threading.Thread(
                target=_listener_loop, name='zros interrupt', daemon=True
            )
            _listener_thread.start()


_main_raising = 0  #: depth of raises_on_interrupt blocks of the main thread


@contextlib.contextmanager
def raises_on_interrupt() -> Iterator[None]:
    """A block of the main thread that Ctrl-C ends with KeyboardInterrupt (when zros handles
    SIGINT): for waits in Zenoh's Rust code, which runs Python's signal handlers but can only
    be left by an exception. Other threads do not get signals: the block does nothing there."""
    global _main_raising  # noqa: PLW0603
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _main_raising += 1
    try:
        if interrupt_flag.value:
            raise KeyboardInterrupt
        yield
    finally:
        _main_raising -= 1


def main_thread_raises() -> bool:
    """Whether the main thread is inside :func:`raises_on_interrupt` (asked by the handler)."""
    return _main_raising > 0


def clear_interrupt() -> None:
    """Let blocking calls block again (a new ``zros.init``)."""
    interrupt_flag.value = False


def add_interrupt_listener(listener: Callable[[], object]) -> None:
    """Call ``listener()`` on :func:`interrupt` (at once if it happened already); it must not
    block. Remove it with :func:`remove_interrupt_listener` when the wait it ends is over."""
    with _listeners_lock:
        _listeners.append(listener)
    if interrupt_flag.value:
        listener()


def remove_interrupt_listener(listener: Callable[[], object]) -> None:
    """Stop calling ``listener`` on interrupt."""
    with _listeners_lock, contextlib.suppress(ValueError):
        _listeners.remove(listener)


#: the longest the main thread sleeps in one go before Python's signal handlers may run
_MAIN_THREAD_SLICE = 0.1
#: the longest another thread sleeps in one go before it looks whether a notify took its lock
_SLICE = 1.0


def _sleep(
    lock: _thread.LockType,
    deadline: float | None,
    waiters: list[_thread.LockType],
    main: bool,
    interruptible: bool,
) -> bool:
    """Go on acquiring ``lock`` (a waiter's) by ``deadline`` (``time.monotonic()``; None: no
    limit), in slices, once its first slice ran out; returns whether it did. :meth:`Signal.wait`
    sleeps the first slice itself (most waits end in it, and a call costs a wake-up a few
    microseconds with cold caches).

    Python runs a signal's handler on the main thread between two bytecodes. A blocked acquire
    is cut short to run it only if the signal lands on the main thread during the acquire; one
    that arrives just before the acquire starts, or lands on another thread (Zenoh's), leaves
    the handler pending, and the acquire would sleep through the Ctrl-C: the main thread sleeps
    0.1 s at a time, and the pending handler runs between slices (and releases this lock
    through :func:`interrupt`). Every thread also ends its wait between slices once a notify
    took its lock out of ``waiters``: the notify's release may never come, if an exception
    (a second Ctrl-C) cut the notifier short.
    """
    length = _MAIN_THREAD_SLICE if main else _SLICE
    while not ((interruptible and interrupt_flag.value) or lock not in waiters):
        if deadline is not None:
            length = min(length, deadline - time.monotonic())
            if length <= 0:
                return False
        if lock.acquire(True, length):
            return True
    return False


def sleep(seconds: float) -> bool:
    """Sleep ``seconds`` unless interrupted; returns False when Ctrl-C cut it short."""
    Signal().wait_for(lambda: False, seconds)
    return not interrupt_flag.value


#: the longest a wait that ran out waits for the release of a notify that took its lock
_RELEASE_GRACE = 1.0


class _Waiting(threading.local):
    """This thread's waiter lock, made once per thread (allocating one per wait cost a wake-up
    a few microseconds with cold caches), and whether this is the main thread. The lock is held
    while the thread does not wait: a notify takes it out of the signal's waiters, then releases
    it, and the wait it ends acquires it again."""

    def __init__(self) -> None:
        self.lock = _thread.allocate_lock()
        self.lock.acquire()
        self.main = threading.current_thread() is threading.main_thread()


_waiting = _Waiting()


class Signal:
    """Lets threads sleep until another thread says something may have changed."""

    __slots__ = ('waiters',)

    def __init__(self) -> None:
        #: the locks of the threads waiting now (empty: notifying costs nothing); read it to
        #: skip :meth:`notify` cheaply, never change it
        self.waiters: list[_thread.LockType] = []

    def __bool__(self) -> bool:
        """Whether a thread is waiting."""
        return bool(self.waiters)

    def wait(
        self, ready: Callable[[], object], timeout: float | None, interruptible: bool = False
    ) -> None:
        """Sleep until notified or ``timeout`` seconds pass, unless ``ready()`` is already true;
        an ``interruptible`` wait also ends on (or right after) :func:`interrupt`."""
        waiting = _waiting
        lock = waiting.lock
        waiters = self.waiters
        waiters.append(lock)
        if interruptible:
            _sleeping.add(lock)
        woken = False
        try:
            if not (ready() or (interruptible and interrupt_flag.value)):
                deadline = None if timeout is None else time.monotonic() + timeout
                first = _MAIN_THREAD_SLICE if waiting.main else _SLICE  # any more in _sleep
                if timeout is not None and timeout < first:
                    first = timeout
                woken = (first > 0 and lock.acquire(True, first)) or _sleep(
                    lock, deadline, waiters, waiting.main, interruptible
                )
        finally:
            if interruptible:
                _sleeping.discard(lock)
            if not woken or lock in waiters:  # woken by a notify: it took the lock out already
                try:
                    waiters.remove(lock)
                except ValueError:  # a notify took it meanwhile: its release is due, take it
                    lock.acquire(True, _RELEASE_GRACE)

    def wait_for(
        self, ready: Callable[[], object], timeout: float | None, interruptible: bool = True
    ) -> bool:
        """Wait until ``ready()`` (True), ``timeout`` seconds (None: no limit) or, if
        ``interruptible``, Ctrl-C (False: :func:`interrupted` tells which)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not ready():
            remaining = None if deadline is None else deadline - time.monotonic()
            if interruptible and interrupt_flag.value:
                return bool(ready())
            if remaining is not None and remaining <= 0:
                return bool(ready())
            self.wait(ready, remaining, interruptible)
        return True

    def notify(self) -> None:
        """Wake every waiting thread."""
        waiters = self.waiters
        while waiters:
            try:  # take the lock out first: a wait that ends meanwhile knows a release comes
                lock = waiters.pop()
            except IndexError:  # another notify took the last one
                return
            try:  # noqa: SIM105 (contextlib.suppress costs 3x the release, once per message)
                lock.release()
            except RuntimeError:  # released already (by interrupt())
                pass
