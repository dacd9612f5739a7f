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
    main thread between two bytecodes, possibly while that thread is inside ``clear()``."""

    __slots__ = ('_value',)

    def __init__(self) -> None:
        self._value = False

    def set(self) -> None:
        self._value = True

    def clear(self) -> None:
        self._value = False

    def is_set(self) -> bool:
        return self._value


_interrupted = _Flag()
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
    return _interrupted.is_set()


def interrupt() -> None:
    """End every interruptible wait now, and make later ones end at once (Ctrl-C).

    Safe in a signal handler: it only releases locks; the listeners run on a thread of their
    own once :func:`start_listener_thread` started it, else right here.
    """
    _interrupted.set()
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
        if _interrupted.is_set():
            raise KeyboardInterrupt
        yield
    finally:
        _main_raising -= 1


def main_thread_raises() -> bool:
    """Whether the main thread is inside :func:`raises_on_interrupt` (asked by the handler)."""
    return _main_raising > 0


def clear_interrupt() -> None:
    """Let blocking calls block again (a new ``zros.init``)."""
    _interrupted.clear()


def add_interrupt_listener(listener: Callable[[], object]) -> None:
    """Call ``listener()`` on :func:`interrupt` (at once if it happened already); it must not
    block. Remove it with :func:`remove_interrupt_listener` when the wait it ends is over."""
    with _listeners_lock:
        _listeners.append(listener)
    if _interrupted.is_set():
        listener()


def remove_interrupt_listener(listener: Callable[[], object]) -> None:
    """Stop calling ``listener`` on interrupt."""
    with _listeners_lock, contextlib.suppress(ValueError):
        _listeners.remove(listener)


#: the longest the main thread sleeps in one go before Python's signal handlers may run
_MAIN_THREAD_SLICE = 0.1


def _sleep_on_main_thread(
    lock: _thread.LockType, timeout: float | None, interruptible: bool
) -> None:
    """Acquire ``lock`` (a waiter's) on the main thread in slices of 0.1 s.

    Python runs a signal's handler on the main thread between two bytecodes. A blocked acquire
    is cut short to run it only if the signal lands on the main thread during the acquire; one
    that arrives just before the acquire starts, or lands on another thread (Zenoh's), leaves
    the handler pending, and the acquire would sleep through the Ctrl-C. Between slices the
    pending handler runs (and releases this lock through :func:`interrupt`).
    """
    deadline = None if timeout is None else time.monotonic() + timeout
    while True:
        length = _MAIN_THREAD_SLICE
        if deadline is not None:
            length = min(length, deadline - time.monotonic())
            if length <= 0:
                return
        if lock.acquire(True, length) or (interruptible and _interrupted.is_set()):
            return


def sleep(seconds: float) -> bool:
    """Sleep ``seconds`` unless interrupted; returns False when Ctrl-C cut it short."""
    Signal().wait_for(lambda: False, seconds)
    return not _interrupted.is_set()


class Signal:
    """Lets threads sleep until another thread says something may have changed."""

    __slots__ = ('_waiters',)

    def __init__(self) -> None:
        self._waiters: list[_thread.LockType] = []

    def __bool__(self) -> bool:
        """Whether a thread is waiting (notifying costs nothing otherwise)."""
        return bool(self._waiters)

    def wait(
        self, ready: Callable[[], object], timeout: float | None, interruptible: bool = False
    ) -> None:
        """Sleep until notified or ``timeout`` seconds pass, unless ``ready()`` is already true;
        an ``interruptible`` wait also ends on (or right after) :func:`interrupt`."""
        lock = _thread.allocate_lock()
        lock.acquire()
        self._waiters.append(lock)
        if interruptible:
            _sleeping.add(lock)
        try:
            if not (ready() or (interruptible and _interrupted.is_set())):
                if threading.get_ident() == threading.main_thread().ident:
                    _sleep_on_main_thread(lock, timeout, interruptible)
                else:
                    lock.acquire(True, -1 if timeout is None else max(timeout, 0.0))
        finally:
            self._waiters.remove(lock)
            _sleeping.discard(lock)

    def wait_for(
        self, ready: Callable[[], object], timeout: float | None, interruptible: bool = True
    ) -> bool:
        """Wait until ``ready()`` (True), ``timeout`` seconds (None: no limit) or, if
        ``interruptible``, Ctrl-C (False: :func:`interrupted` tells which)."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not ready():
            remaining = None if deadline is None else deadline - time.monotonic()
            if (interruptible and _interrupted.is_set()) or (
                remaining is not None and remaining <= 0
            ):
                return bool(ready())
            self.wait(ready, remaining, interruptible)
        return True

    def notify(self) -> None:
        """Wake every waiting thread."""
        for lock in tuple(self._waiters):
            try:  # noqa: SIM105 (contextlib.suppress costs 3x the release, once per message)
                lock.release()
            except RuntimeError:  # already released by an earlier notify
                pass
