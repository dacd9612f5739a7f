"""Futures of service calls and goals, which the first Ctrl-C fails.

``call_async`` (and the action client) return a :class:`ServiceFuture`: a
``concurrent.futures.Future`` that is also awaitable. After Ctrl-C (with ``zros.init``'s
handler) every unfinished one fails with KeyboardInterrupt, so ``result()`` and ``await`` end.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import weakref
from collections.abc import Generator
from typing import Protocol, TypeVar

from zros.runtime.signal import add_interrupt_listener, interrupted

T = TypeVar('T')


class ServiceFuture(concurrent.futures.Future[T]):
    """The pending result of ``call_async``: ``result(timeout)``, or ``await`` it.

    After Ctrl-C (with ``zros.init``'s handler) every pending one fails with KeyboardInterrupt,
    so waiting for it ends.
    """

    def __init__(self) -> None:
        super().__init__()
        self.set_running_or_notify_cancel()
        _unfinished.add(self)
        self.add_done_callback(_forget)
        if interrupted():
            self.settle(KeyboardInterrupt())

    def settle(self, outcome: T | BaseException) -> None:
        """Finish with ``outcome`` (a BaseException fails it), unless already finished."""
        with contextlib.suppress(concurrent.futures.InvalidStateError):
            if isinstance(outcome, BaseException):
                self.set_exception(outcome)
            else:
                self.set_result(outcome)

    def __await__(self) -> Generator[object, None, T]:
        return asyncio.wrap_future(self).__await__()


class _Settles(Protocol):
    def settle(self, outcome: BaseException) -> None: ...


_unfinished: weakref.WeakSet[_Settles] = weakref.WeakSet()


def _forget(future: concurrent.futures.Future[T]) -> None:
    if isinstance(future, ServiceFuture):
        _unfinished.discard(future)


def _interrupt_unfinished() -> None:
    for future in list(_unfinished):
        future.settle(KeyboardInterrupt())


add_interrupt_listener(_interrupt_unfinished)
