"""A signal handler runs on the main thread between two bytecodes, possibly while that thread
holds a lock the handler would take: the handlers of zros (``zros.init``'s Ctrl-C, the CLI's
SIGINT/SIGTERM) take none, so a signal never hangs the process, wherever it lands."""

from __future__ import annotations

import subprocess
import sys

ROUNDS = 1000

#: each round waits on the stop event in a tight loop while a timer thread sends SIGINT: the
#: handler then often runs inside ``stop.wait()``, while the event's lock is held
STOP_EVENT = f"""
import os, signal, threading
from zros.cli.signals import stop_on_signals

for _ in range({ROUNDS}):
    stop = threading.Event()
    with stop_on_signals(stop):
        threading.Timer(0.0005, os.kill, (os.getpid(), signal.SIGINT)).start()
        while not stop.wait(0):
            pass
print('done')
"""

#: zros.init's handler interrupts while the main thread clears the interrupt (a new init)
INTERRUPT_FLAG = f"""
import os, signal, threading
from zros.runtime import signal as zros_signal

fired = []

def handler(signum, frame):
    zros_signal.interrupt()
    fired.append(signum)

signal.signal(signal.SIGINT, handler)
for round_ in range({ROUNDS}):
    threading.Timer(0.0005, os.kill, (os.getpid(), signal.SIGINT)).start()
    while len(fired) <= round_:
        zros_signal.clear_interrupt()
print('done')
"""


def _survives(script: str) -> None:
    try:
        done = subprocess.run(
            [sys.executable, '-c', script], check=False, capture_output=True, text=True,
            timeout=120,
        )  # fmt: skip
    except subprocess.TimeoutExpired:  # run() killed the child
        raise AssertionError('a signal hung the process') from None
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == 'done'


def test_a_signal_inside_the_wait_for_it_stops_the_command() -> None:
    """CI caught ``zros bag record`` hanging after SIGINT: its handler set the stop event from
    inside ``stop.wait()`` and waited for ever for the lock that wait held."""
    _survives(STOP_EVENT)


def test_ctrl_c_while_the_interrupt_is_cleared() -> None:
    _survives(INTERRUPT_FLAG)
