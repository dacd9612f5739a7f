"""How a ``zros`` command ends on a signal: SIGTERM as Ctrl-C, a stop event set on either, and
a server's wait for Ctrl-C."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

from zros.cli.shared import out


class Terminated(KeyboardInterrupt):
    """SIGTERM (``docker stop``, systemd), raised where Ctrl-C raises KeyboardInterrupt."""


@contextmanager
def sigterm_as_ctrl_c() -> Iterator[None]:
    """While a command runs, SIGTERM ends it as Ctrl-C does (a :class:`Terminated`), instead of
    killing the process before it closes what it holds; :func:`stop_on_signals` inside takes
    over. Only on the main thread, and only where nobody chose another SIGTERM handler."""
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        raise Terminated

    signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


@contextmanager
def stop_on_signals(stop: threading.Event) -> Iterator[None]:
    """SIGINT and SIGTERM set ``stop`` instead of killing the process (restored after).

    The handler runs on the main thread between two bytecodes, possibly inside ``stop.wait()``
    while that holds the event's lock: setting the event there would wait for that lock for
    ever. A thread of its own sets it, once the main thread lets go."""

    def handler(signum: int, frame: FrameType | None) -> None:
        threading.Thread(target=stop.set, name='zros stop signal', daemon=True).start()

    saved = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, previous in saved.items():
            signal.signal(sig, previous)


def serve_until_interrupted(announce: str) -> int:
    """Print ``announce`` and wait for Ctrl-C while a server runs on threads of its own; exit
    code 0. The line is printed inside the wait: a signal sent as soon as it is read (a
    supervisor, a test) still ends the command as Ctrl-C does."""
    idle = threading.Event()  # never set: a sleep Ctrl-C interrupts
    try:
        out(announce)
        while not idle.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    return 0
