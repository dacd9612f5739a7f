"""Closing an entity while another thread uses it."""

from __future__ import annotations

import threading
from collections.abc import Callable

from zros.runtime.entity import Entity


def close_while_used(entity: Entity, use: Callable[[], object]) -> tuple[object, list[Exception]]:
    """Close ``entity`` while another thread calls ``use()`` on it again and again, until a
    call raises or the close has ended, and then once more. Returns what that last call
    returned (None when a call raised) and what the calls raised."""
    started, closed = threading.Event(), threading.Event()
    last: list[object] = []
    errors: list[Exception] = []

    def run() -> None:
        started.set()
        try:
            while not closed.is_set():
                use()
            last.append(use())
        except Exception as error:
            errors.append(error)

    user = threading.Thread(target=run, daemon=True)
    user.start()
    assert started.wait(10)
    entity.close()
    closed.set()
    user.join(10)
    assert not user.is_alive()
    return (last[0] if last else None), errors
