"""What a layer above keeps per Zenoh session (the graph's view, the bridges a wire found...).

The transport knows nothing of those layers: each keeps its own :class:`PerSession` table, made
on first use and forgotten with the session.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable
from typing import Generic, TypeVar

from zros.transport.session import Transport

T = TypeVar('T')


class PerSession(Generic[T]):
    """One value per :class:`Transport`, made by ``factory(transport)`` on first use."""

    def __init__(self, factory: Callable[[Transport], T]) -> None:
        self._factory = factory
        self._values: weakref.WeakKeyDictionary[Transport, T] = weakref.WeakKeyDictionary()
        self._lock = threading.Lock()

    def __call__(self, transport: Transport) -> T:
        """The value of ``transport`` (made now if it has none)."""
        with self._lock:
            value = self._values.get(transport)
            if value is None:
                value = self._values[transport] = self._factory(transport)
            return value

    def peek(self, transport: Transport) -> T | None:
        """The value of ``transport`` if one was made, else None."""
        with self._lock:
            return self._values.get(transport)
