"""What an echo runs per message: the Python functions and C calls on each of its threads, for
zros's echo (spinning and immediate) against raw zenoh-python echoes doing the least the same
structure needs (row e's floors of ``transport.py``); and what zros's ping runs, on the
pinging thread and its pong subscription's delivery thread.

At one message every few hundred microseconds each one runs with cold caches, where a Python
function call costs microseconds instead of a tenth of one (DESIGN, "where a round trip's time
goes"): the count of what runs is what sets the echo's share of a round trip, and unlike a
time it is the same on every run and every machine. One process: a router, a pinger (raw
zenoh-python) and the echo under test, profiled with ``threading.setprofile`` while the pinger
waits for each pong (its own threads are left out).

    python benchmarks/transport_calls.py [--pings N] [--verbose]
"""

from __future__ import annotations

import _thread
import argparse
import collections
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any

HERE = Path(__file__).resolve()
sys.path[:0] = [str(HERE.parent), str(HERE.parents[1])]

from transport_roles import fast_codec, raw_session, relayed, zros_node  # noqa: E402

PING, PONG = 'bench/ping_calls', 'bench/pong_calls'
#: the thread names of the echoes under test (the pinger's threads have others)
ECHO_THREADS = ('echo spin', 'echo relay', PING)
Stop = Callable[[], None]


def raw_relay(endpoint: str) -> Stop:
    """Row e's ``zenoh_relay_dec``: a FIFO channel drained by a thread of its own, which hands
    the pings to the spinning thread; that one decodes each, encodes it again and puts it."""
    session = raw_session(endpoint, False)
    put = session.declare_publisher(PONG).put
    decode, encode = fast_codec('std_msgs/msg/Float64')
    pings: collections.deque[Any] = collections.deque()
    arrived = _thread.allocate_lock()
    arrived.acquire()
    channel = relayed(session, PING, pings, arrived, 'echo relay')
    done = threading.Event()

    def spin() -> None:
        while not done.is_set():
            arrived.acquire(True, 0.1)
            while pings:
                put(encode(decode(pings.popleft().to_bytes(), False)))

    spinner = threading.Thread(target=spin, name='echo spin')
    spinner.start()

    def stop() -> None:
        done.set()
        spinner.join()
        channel.undeclare()
        session.close()

    return stop


def zros_echo(endpoint: str, impl: str) -> Stop:
    """``transport.py``'s zros echo: a subscription whose callback is the publisher's
    ``write``, the node spun on a thread of its own (``zros``), or callbacks run as messages
    arrive (``zros_now``)."""
    node = zros_node('bench_echo', endpoint, False, False, impl)
    publisher = node.create_publisher('std_msgs/msg/Float64', '/' + PONG)
    node.create_subscription('std_msgs/msg/Float64', '/' + PING, publisher.write, qos=100)
    spinner = threading.Thread(target=node.spin, name='echo spin')
    spinner.start()

    def stop() -> None:
        node.destroy()  # its spin returns
        spinner.join()
        node.transport.close()

    return stop


Calls = collections.Counter[tuple[str, str, str]]


class CallCounter:
    """A profile function (``threading.setprofile``) counting the Python functions and C calls
    on the threads named ``threads`` (delivery threads by their key) while :meth:`count` runs."""

    def __init__(self, threads: tuple[str, ...]) -> None:
        self.threads = threads
        self.calls: Calls = collections.Counter()
        self.active = False
        self.skip: object = None  #: the code of the round trip itself, not counted

    def __call__(self, frame: FrameType, event: str, arg: Any) -> None:
        if not self.active or event not in ('call', 'c_call'):
            return
        thread = threading.current_thread().name.removesuffix(' (zros delivery)')
        if thread not in self.threads:
            return
        if event == 'call':
            code = frame.f_code
            if code is self.skip:
                return
            name = f'{code.co_name} ({Path(code.co_filename).name}:{code.co_firstlineno})'
            self.calls[thread, 'py', name] += 1
        else:
            self.calls[thread, 'c', getattr(arg, '__qualname__', repr(arg))] += 1

    def count(self, round_trip: Callable[[], None], pings: int) -> Calls:
        """Calls per round trip over ``pings`` round trips, after 50 that compile the codecs
        and warm the caches."""
        for _ in range(50):
            round_trip()
        self.skip = round_trip.__code__
        self.active = True
        for _ in range(pings):
            round_trip()
        self.active = False
        return collections.Counter({key: round(n / pings, 2) for key, n in self.calls.items()})


def measure(endpoint: str, start: Callable[[], Stop], pings: int) -> Calls:
    """Calls per round trip on the echo's threads: (thread, 'py' or 'c', name) -> count."""
    import zros
    from zros.cdr import encode

    counter = CallCounter(ECHO_THREADS)
    threading.setprofile(counter)  # for the threads the echo starts
    stop = start()
    session = raw_session(endpoint, False)
    got = threading.Event()
    pongs = session.declare_subscriber(PONG, lambda _: got.set())
    publisher = session.declare_publisher(PING)
    deadline = time.monotonic() + 30
    while not publisher.matching_status.matching:
        if time.monotonic() > deadline:
            raise RuntimeError('the echo did not subscribe')
        time.sleep(0.01)
    data = encode(zros.Message('std_msgs/msg/Float64', data=1.0))

    def ping() -> None:
        got.clear()
        publisher.put(data)
        if not got.wait(10):
            raise RuntimeError('no pong')

    calls = counter.count(ping, pings)
    threading.setprofile(None)  # type: ignore[arg-type]
    pongs.undeclare()
    session.close()
    stop()
    return calls


def measure_ping(endpoint: str, pings: int) -> Calls:
    """Calls per round trip of zros's ping (``write``, then ``wait_for_message``) against a raw
    echo, on the pinging thread and the pong subscription's delivery thread."""
    import zros

    counter = CallCounter(('MainThread', PONG))
    session = raw_session(endpoint, False)
    put = session.declare_publisher(PONG).put
    echo = session.declare_subscriber(PING, lambda sample: put(sample.payload))
    threading.setprofile(counter)  # for the delivery thread the subscription starts
    node = zros_node('bench_ping', endpoint, False)
    pongs = node.create_subscription('std_msgs/msg/Float64', '/' + PONG, qos=100)
    publisher = node.create_publisher('std_msgs/msg/Float64', '/' + PING)
    if not publisher.wait_for_subscribers(30):
        raise RuntimeError('the echo did not subscribe')
    message = zros.Message('std_msgs/msg/Float64', data=1.0)

    def ping() -> None:
        publisher.write(message)
        if pongs.wait_for_message(10) is None:
            raise RuntimeError('no pong')

    sys.setprofile(counter)  # this thread
    calls = counter.count(ping, pings)
    sys.setprofile(None)
    threading.setprofile(None)  # type: ignore[arg-type]
    node.destroy()
    node.transport.close()
    echo.undeclare()
    session.close()
    return calls


def report(label: str, calls: Calls, verbose: bool) -> None:
    totals: collections.Counter[tuple[str, str]] = collections.Counter()
    for (thread, kind, _), count in calls.items():
        totals[thread, kind] += count
    threads = sorted({thread for thread, _ in totals})
    cells = ', '.join(
        f'{thread}: {totals[thread, "py"]:g} Python + {totals[thread, "c"]:g} C'
        for thread in threads
    )
    py = sum(v for (_, kind), v in totals.items() if kind == 'py')
    print(f'{label:36} {py:>6g}   {cells}')
    if verbose:
        for (thread, kind, name), count in sorted(calls.items()):
            if count >= 0.5:
                print(f'      {thread:12} {kind:2} {count:>5g}  {name}')


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--pings', type=int, default=200)
    parser.add_argument('--verbose', action='store_true', help='every function, per thread')
    args = parser.parse_args()
    from zros.transport import start_router

    router = start_router(shared_memory=False)
    endpoint = router.endpoint
    echoes: dict[str, Callable[[], Stop]] = {
        'raw relay echo, decodes (floor)': lambda: raw_relay(endpoint),
        'zros echo (spin)': lambda: zros_echo(endpoint, 'zros'),
        'zros echo (immediate)': lambda: zros_echo(endpoint, 'zros_now'),
    }
    print(f"calls per round trip on the echo's threads, {args.pings} pings through a router")
    print(f'{"":36} {"Python":>6}   per thread')
    try:
        for label, start in echoes.items():
            report(label, measure(endpoint, start, args.pings), args.verbose)
        report('zros ping (against a raw echo)', measure_ping(endpoint, args.pings), args.verbose)
    finally:
        router.close()


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()
