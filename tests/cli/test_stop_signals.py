"""Commands that run until SIGINT or SIGTERM (``bag record``, ``bag play``, ``router``) stop on
the first one, wherever the main thread is when it lands."""

from __future__ import annotations

import subprocess
import sys

ROUNDS = 1000

#: each round waits on the stop event in a tight loop while a timer thread sends SIGINT: the
#: handler then often runs inside ``stop.wait()``, while the event's lock is held
SCRIPT = f"""
import os, signal, threading
from zros.cli.shared import stop_on_signals

for _ in range({ROUNDS}):
    stop = threading.Event()
    with stop_on_signals(stop):
        threading.Timer(0.0005, os.kill, (os.getpid(), signal.SIGINT)).start()
        while not stop.wait(0):
            pass
print('stopped every time')
"""


def test_a_signal_inside_the_wait_for_it_stops_the_command() -> None:
    """CI caught ``zros bag record`` hanging after SIGINT: its handler set the stop event from
    inside ``stop.wait()`` and waited for ever for the lock that wait held."""
    try:
        done = subprocess.run(
            [sys.executable, '-c', SCRIPT], check=False, capture_output=True, text=True,
            timeout=120,
        )  # fmt: skip
    except subprocess.TimeoutExpired:  # the child is killed by run()
        raise AssertionError('a signal that landed inside stop.wait() hung the process') from None
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == 'stopped every time'
