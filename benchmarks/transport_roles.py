"""The process roles of ``benchmarks/transport.py``: publishers, subscribers, echo and ping.

Each role runs in a process of its own (``transport.py --role ...``) and prints one JSON line.
Implementations (``--impl``):

  * ``zenoh``: zenoh-python alone; its subscriber only takes the bytes of each sample;
  * ``zenoh_decode``: zenoh-python, whose subscriber also decodes them with zros's codec;
  * ``zenoh_codec``: as ``zenoh_decode``, whose publisher also encodes every message (the
    others send the bytes of one, encoded once): the least a node that publishes and
    receives messages does;
  * ``zenoh_rmw``: as ``zenoh_decode``, with rmw_zenoh's 33-byte attachment on every message,
    which the subscriber checks before it decodes (what that wire costs raw zenoh-python);
  * ``zros``, ``zros_rmw``: a zros node on the bridge's keys or on rmw_zenoh's, whose
    subscriber has a callback run by ``spin_once`` (the ROS way);
  * ``zros_poll``: a zros node read the rosR way, ``spin_once(0.01)`` then
    ``has_new_message()`` and ``take()``;
  * ``zros_now``: a zros node with ``immediate_callbacks`` (callbacks run on the delivery
    thread as messages arrive, not inside ``spin``).

More take part in the split round trip (row e) only: ``zenoh_spin``, an echo whose callback
hands each ping to the main thread, which sends the pong (what running callbacks inside
``spin`` costs raw zenoh-python); ``zenoh_dec`` and ``zenoh_spin_dec``, the raw echoes that
also decode each ping and encode the pong with zros's codec (the least an echo that hands
messages to user code does); ``zenoh_relay_dec``, as ``zenoh_spin_dec`` with zros's
structure (a FIFO channel drained by a thread of its own, handing the pings to the spinning
thread); ``zenoh_fifo_dec``, zros's immediate callbacks with nothing of zros (a FIFO channel
drained by a thread of its own, which decodes, encodes and puts). As pings: ``zenoh_dec``,
encoding each ping and decoding each pong; ``zenoh_relay_dec``, the same with zros's structure
(the pongs come through a FIFO channel drained by a thread of its own, which wakes the pinging
thread, which decodes); and ``zenoh_fifo``, waiting for its pong in a FIFO channel's ``recv``
(no Python thread in between: the fastest raw ping).

Payloads (``--kind``): ``string`` (std_msgs/String), ``image`` (sensor_msgs/Image 1080p rgb8),
``bytes<N>`` (std_msgs/UInt8MultiArray with N bytes of data).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

#: the script that plays the roles (``--role``)
SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'transport.py')
#: competitors named ``<impl>@before`` import zros from this checkout (``transport.py --against``)
BEFORE = '@before'
against: str | None = None

#: how long a publisher waits after its last message (the subscriber drains its queue)
LINGER = 1.0
#: the subscriber of the rosR polling path reads this often
POLL_PERIOD = 0.01


def raw_session(endpoint: str, shm: bool, peer: bool = False) -> Any:
    """A zenoh-python session with the settings zros's transport gives its own."""
    import zenoh

    settings: dict[str, Any] = {
        'mode': 'peer' if peer else 'client',
        'connect': {'endpoints': [endpoint]},
        'scouting': {'multicast': {'enabled': False}},
        'transport': {'shared_memory': {'enabled': shm}},
        'timestamping': {'enabled': True},
    }
    if peer:
        settings['listen'] = {'endpoints': ['tcp/127.0.0.1:0']}
    return zenoh.open(zenoh.Config.from_json5(json.dumps(settings)))


def zros_node(name: str, endpoint: str, shm: bool, peer: bool = False, impl: str = 'zros') -> Any:
    """A zros node on a session of its own (``impl`` 'zros_rmw': on the rmw_zenoh wire;
    'zros_now': with immediate callbacks)."""
    import zros
    from zros.transport import Transport, TransportConfig

    config = TransportConfig.create(
        connect=endpoint,
        shared_memory=shm,
        mode='peer' if peer else 'client',
        listen='tcp/127.0.0.1:0' if peer else None,
    )
    wire = 'rmw_zenoh' if impl == 'zros_rmw' else 'bridge'
    options = {'immediate_callbacks': True} if impl == 'zros_now' else {}
    return zros.Node(name, transport=Transport(config), wire=wire, **options)


def type_of(kind: str) -> str:
    """The message type of a payload kind."""
    if kind == 'string':
        return 'std_msgs/msg/String'
    if kind == 'image':
        return 'sensor_msgs/msg/Image'
    return 'std_msgs/msg/UInt8MultiArray'


def payload(kind: str) -> Any:
    """The message a publisher sends over and over."""
    import numpy as np

    import zros

    if kind == 'string':
        return zros.Message('std_msgs/msg/String', data='hello zros, a short message')
    if kind == 'image':
        image = zros.Message(
            'sensor_msgs/msg/Image', height=1080, width=1920, encoding='rgb8', step=5760
        )
        image.data = np.random.default_rng(1).integers(0, 256, 1920 * 1080 * 3, dtype=np.uint8)
        return image
    size = int(kind.removeprefix('bytes'))
    message = zros.Message(type_of(kind))
    message.data = np.random.default_rng(1).integers(0, 256, size, dtype=np.uint8)
    return message


def encoded_size(kind: str) -> int:
    """The bytes of one message of ``kind`` on the wire (CDR header included)."""
    from zros.cdr import encode

    return len(encode(payload(kind)))


def role_publish(args: argparse.Namespace) -> None:
    """Send ``count`` messages as fast as the transport takes them, then print the CPU seconds
    that took (all threads). With ``--turns``: after ``ready``, each line ``N`` read from stdin
    sends N messages and prints their CPU seconds; ends at EOF."""
    message = payload(args.kind)
    key = f'bench/data{args.tag}'
    if args.impl.startswith('zenoh'):
        import zenoh

        from zros.cdr import encode

        session = raw_session(args.endpoint, args.shm)
        publisher = session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
        while not publisher.matching_status.matching:
            time.sleep(0.001)
        data = encode(message)
        put = publisher.put
        if args.impl == 'zenoh_rmw':
            from zros.wire import SequenceNumbers

            put = SequenceNumbers(bytes(range(16))).sender(put)
        send, item, close = put, data, session.close
        if args.impl == 'zenoh_codec':  # each message encoded, as a publisher of messages must
            encode_fast = fast_codec(message.__msgtype__)[1]

            def send(message: Any) -> None:
                put(encode_fast(message))

            item = message
    else:
        node = zros_node('bench_pub', args.endpoint, args.shm, impl=args.impl)
        zros_publisher = node.create_publisher(message.__msgtype__, '/' + key, qos='keep_all')
        zros_publisher.wait_for_subscribers(30)
        send, item, close = zros_publisher.write, message, node.transport.close

    def burst(count: int) -> float:
        cpu = time.process_time()
        for _ in range(count):
            send(item)
        return time.process_time() - cpu

    if args.turns:
        print('ready', flush=True)
        for line in sys.stdin:
            print(json.dumps({'cpu': burst(int(line))}), flush=True)
    else:
        cpu = burst(args.count)
        time.sleep(LINGER)
        print(json.dumps({'cpu': cpu}))
    close()


def stat_seconds(stat: Path) -> float:
    """The CPU seconds (user and system) a /proc ``stat`` file gives; NaN where it cannot be
    read (the process or thread ended, or no /proc)."""
    try:
        fields = stat.read_text().rsplit(')', 1)[1].split()
    except OSError:
        return float('nan')
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def cpu_seconds(pid: int) -> float:
    """CPU seconds a process has used so far, all threads (Linux; NaN elsewhere)."""
    return stat_seconds(Path(f'/proc/{pid}/stat'))


def thread_seconds(pid: int) -> dict[int, float]:
    """CPU seconds each thread of a process has used so far (Linux; empty elsewhere)."""
    try:
        tasks = list(Path(f'/proc/{pid}/task').iterdir())
    except OSError:
        return {}
    found = {int(task.name): stat_seconds(task / 'stat') for task in tasks}
    return {tid: seconds for tid, seconds in found.items() if not math.isnan(seconds)}


def busiest_thread(before: dict[int, float], after: dict[int, float]) -> float:
    """The most CPU seconds one thread used between two ``thread_seconds`` readings."""
    return max((cpu - before.get(tid, 0.0) for tid, cpu in after.items()), default=float('nan'))


class Counter:
    """Arrival times of the first and the last message, and how many came."""

    def __init__(self, count: int) -> None:
        self.count = count
        self.reset()

    def reset(self) -> None:
        """Count anew (the next turn)."""
        self.received = 0
        self.first = self.last = 0.0
        self.cpu_first = self.cpu_last = 0.0  # this process's CPU seconds (all threads)
        self.threads_first: dict[int, float] = {}  # and each thread's
        self.threads_last: dict[int, float] = {}
        self.done = threading.Event()

    def add(self, messages: int = 1) -> None:
        """Count ``messages`` arriving now."""
        now = time.perf_counter()
        if self.received == 0:
            self.first = now
            self.cpu_first = time.process_time()
            self.threads_first = thread_seconds(os.getpid())
            messages -= 1  # the clock starts at the first one
            self.received = 1
        self.received += messages
        self.last = now
        if self.received >= self.count and not self.done.is_set():
            self.cpu_last = time.process_time()
            self.threads_last = thread_seconds(os.getpid())
            self.done.set()

    def result(self, size: int) -> dict[str, Any]:
        """The JSON line of the subscriber (``cpu``: its CPU seconds from the first message to
        the last; ``cpu_thread``: those of its busiest thread)."""
        elapsed = max(self.last - self.first, 1e-9)
        rate = (self.received - 1) / elapsed
        cpu = self.cpu_last - self.cpu_first
        return {
            'received': self.received, 'expected': self.count, 'rate': rate, 'size': size,
            'cpu': cpu, 'cpu_thread': busiest_thread(self.threads_first, self.threads_last),
        }  # fmt: skip


def fast_codec(type_name: str) -> tuple[Any, Any]:
    """The compiled decoder and encoder of a type, as zros's entities call them (``decode(buf,
    strict)``, ``encode(message)``): a class's ``_cdr_decode`` and ``_cdr_encode`` are stubs
    that compile on their first call, and one bound before that stays a stub."""
    from zros.cdr import encode, get_class
    from zros.cdr.classes import compiled_decoder

    cls = get_class(type_name)
    encode(cls())  # compiles the encoder
    return compiled_decoder(cls), cls._cdr_encode


def role_subscribe(args: argparse.Namespace) -> None:
    """Receive (and decode) ``count`` messages; print the rate between the first and the last.
    With ``--turns``: print that line for every ``count`` messages, until killed."""
    from zros.cdr import get_class

    cls = get_class(type_of(args.kind))
    decode = fast_codec(cls.__msgtype__)[0]
    counter = Counter(args.count)
    key = f'bench/data{args.tag}'
    size = encoded_size(args.kind)

    def turn_over() -> bool:
        """Whether the subscriber is done: after its one run, or (turns) never."""
        if not counter.done.is_set():
            return False
        if not args.turns:
            return True
        print(json.dumps(counter.result(size)), flush=True)
        counter.reset()
        return False

    if args.impl.startswith('zenoh'):
        add = counter.add
        if args.impl == 'zenoh':

            def on_sample(sample: Any) -> None:
                sample.payload.to_bytes()
                add()

        elif args.impl == 'zenoh_rmw':
            from zros.wire.rmw_zenoh_wire import has_attachment

            def on_sample(sample: Any) -> None:
                if has_attachment(sample):
                    decode(sample.payload.to_bytes(), False)
                    add()

        else:

            def on_sample(sample: Any) -> None:
                decode(sample.payload.to_bytes(), False)
                add()

        session = raw_session(args.endpoint, args.shm)
        subscriber = session.declare_subscriber(key, on_sample)
        print('ready', flush=True)
        deadline = time.monotonic() + args.timeout
        while time.monotonic() < deadline:
            counter.done.wait(0.5)
            if turn_over():
                break
        subscriber.undeclare()
        session.close()
    else:
        import zros
        from zros.qos import KEEP_ALL

        node = zros_node('bench_sub', args.endpoint, args.shm, impl=args.impl)
        deadline = time.monotonic() + args.timeout
        if args.impl == 'zros_poll':
            subscriber = node.create_subscription(cls, '/' + key, qos=KEEP_ALL)
            print('ready', flush=True)
            while time.monotonic() < deadline and not turn_over():
                node.spin_once(POLL_PERIOD)
                if subscriber.has_new_message():
                    counter.add(len(subscriber.take()))
        else:  # zros_bytes: the messages' bytes, not decoded (what zros adds besides decoding)
            raw = args.impl == 'zros_bytes'
            zros.Subscriber('/' + key, cls, lambda _: counter.add(), KEEP_ALL, node=node, raw=raw)
            print('ready', flush=True)
            while time.monotonic() < deadline and not turn_over():
                node.spin_once(0.5)
        node.transport.close()
    if not args.turns:
        print(json.dumps(counter.result(size)))


def role_echo(args: argparse.Namespace) -> None:
    """Send every ping back as a pong (on the keys of ``--tag``)."""
    ping, pong = f'bench/ping{args.tag}', f'bench/pong{args.tag}'
    if args.impl.startswith(('zenoh_spin', 'zenoh_relay')):
        _raw_spinning_echo(args, ping, pong)
    elif args.impl == 'zenoh_fifo_dec':
        _raw_fifo_echo(args, ping, pong)
    elif args.impl.startswith('zenoh'):
        session = raw_session(args.endpoint, args.shm, args.peer)
        publisher = session.declare_publisher(pong)
        answer = _pong(args.impl, publisher.put)
        subscriber = session.declare_subscriber(ping, lambda s: answer(s.payload))
        print('ready', flush=True)
        threading.Event().wait(args.timeout)
        subscriber.undeclare()
        session.close()
    else:
        node = zros_node('bench_echo', args.endpoint, args.shm, args.peer, args.impl)
        publisher = node.create_publisher('std_msgs/msg/Float64', '/' + pong)
        node.create_subscription('std_msgs/msg/Float64', '/' + ping, publisher.write, qos=100)
        print('ready', flush=True)
        node.spin(timeout=args.timeout)
        node.transport.close()


def _pong(impl: str, put: Any) -> Any:
    """What a raw echo does with a ping's payload: put it back, or (``..._dec``) decode it as
    the message and put the message encoded again, as any echo handing messages to user code
    must (zros's codec: the least that costs)."""
    if not impl.endswith('_dec'):
        return put
    decode, encode = fast_codec('std_msgs/msg/Float64')

    def answer(payload: Any) -> None:
        put(encode(decode(payload.to_bytes(), False)))

    return answer


def relayed(session: Any, key: str, pings: Any, arrived: Any, name: str = 'relay') -> Any:
    """A subscriber on ``key`` whose FIFO channel a thread of its own drains (``recv``, then
    ``try_recv`` until it is empty), handing each batch's payloads to ``pings.extend`` (a deque)
    and releasing the lock ``arrived`` if it is held: zros's structure, with nothing of zros."""
    import zenoh

    channel = session.declare_subscriber(key, zenoh.handlers.FifoChannel(256))

    def relay(recv: Any = channel.handler.recv, try_recv: Any = channel.handler.try_recv) -> None:
        with contextlib.suppress(zenoh.ZError):  # the channel closed
            while True:
                batch = [recv()]
                while (sample := try_recv()) is not None:
                    batch.append(sample)
                pings.extend(sample.payload for sample in batch)
                if arrived.locked():
                    arrived.release()

    threading.Thread(target=relay, name=name, daemon=True).start()
    return channel


class _Answering:
    """What :func:`relayed` hands a batch of pings to, answering each on the relay thread."""

    def __init__(self, answer: Any) -> None:
        self.answer = answer

    def extend(self, payloads: Any) -> None:
        for payload in payloads:
            self.answer(payload)


def _raw_fifo_echo(args: argparse.Namespace, ping: str, pong: str) -> None:
    """zros's immediate callbacks with nothing of zros: the pings come through a FIFO channel
    that a thread of the echo's own drains, which decodes each, encodes the pong and puts it."""
    session = raw_session(args.endpoint, args.shm, args.peer)
    publisher = session.declare_publisher(pong)
    never_held = threading.Lock()
    subscriber = relayed(session, ping, _Answering(_pong(args.impl, publisher.put)), never_held)
    print('ready', flush=True)
    threading.Event().wait(args.timeout)
    subscriber.undeclare()
    session.close()


def _raw_spinning_echo(args: argparse.Namespace, ping: str, pong: str) -> None:
    """zenoh-python's callback hands the ping to the main thread (the least a Python hand-over
    takes: a deque and a lock released), which sends the pong. ``zenoh_relay...``: the pings
    come through a FIFO channel drained by a thread of the echo's own instead (``recv``, then
    ``try_recv`` until it is empty), which hands them over the same way (:func:`relayed`)."""
    import _thread
    import collections

    session = raw_session(args.endpoint, args.shm, args.peer)
    publisher = session.declare_publisher(pong)
    pings: collections.deque[Any] = collections.deque()
    arrived = _thread.allocate_lock()
    arrived.acquire()

    def on_ping(sample: Any) -> None:
        pings.append(sample.payload)
        if arrived.locked():
            arrived.release()

    if args.impl.startswith('zenoh_relay'):
        subscriber = relayed(session, ping, pings, arrived)
    else:
        subscriber = session.declare_subscriber(ping, on_ping)
    answer = _pong(args.impl, publisher.put)
    print('ready', flush=True)
    deadline = time.monotonic() + args.timeout
    while time.monotonic() < deadline:
        arrived.acquire(True, 0.1)
        while pings:
            answer(pings.popleft())
    subscriber.undeclare()
    session.close()


#: round trips a pinger makes before it says it is ready (not timed)
WARM_UP = 100


def role_ping(args: argparse.Namespace) -> None:
    """Ping the echo of ``--tag``: after a warm-up, each line ``N`` read from stdin makes N
    round trips, and their times in seconds are printed as one JSON list; ends at EOF."""
    import zros

    message = zros.Message('std_msgs/msg/Float64', data=0.0)
    ping_key, pong_key = f'bench/ping{args.tag}', f'bench/pong{args.tag}'
    if args.impl.startswith('zenoh'):
        from zros.cdr import encode

        got = threading.Event()
        session = raw_session(args.endpoint, args.shm, args.peer)
        if args.impl == 'zenoh_fifo':
            import zenoh

            pongs = session.declare_subscriber(pong_key, zenoh.handlers.FifoChannel(16))
            wait = pongs.handler.recv
        elif args.impl == 'zenoh_relay_dec':  # zros's structure: a FIFO, a thread, a wake-up
            import _thread
            import collections

            decode = fast_codec('std_msgs/msg/Float64')[0]
            pongs_in: collections.deque[Any] = collections.deque()
            arrived = _thread.allocate_lock()
            arrived.acquire()
            pongs = relayed(session, pong_key, pongs_in, arrived)  # kept: dropped, it undeclares

            def wait() -> None:
                while not pongs_in:
                    arrived.acquire(True, 2)
                decode(pongs_in.popleft().to_bytes(), False)

        elif args.impl == 'zenoh_dec':  # each pong decoded, each ping encoded: zros's codec
            decode = fast_codec('std_msgs/msg/Float64')[0]

            def on_pong(sample: Any) -> None:
                decode(sample.payload.to_bytes(), False)
                got.set()

            session.declare_subscriber(pong_key, on_pong)
        else:
            session.declare_subscriber(pong_key, lambda s: got.set())
        if args.impl not in ('zenoh_fifo', 'zenoh_relay_dec'):

            def wait() -> None:
                got.wait(2)
                got.clear()

        publisher = session.declare_publisher(ping_key)
        while not publisher.matching_status.matching:
            time.sleep(0.001)
        data = encode(message)
        close = session.close
        fresh = args.impl in ('zenoh_dec', 'zenoh_relay_dec')

        def round_trip() -> float:
            start = time.perf_counter()
            publisher.put(encode(message) if fresh else data)
            wait()
            return time.perf_counter() - start

    else:
        node = zros_node('bench_ping', args.endpoint, args.shm, args.peer, args.impl)
        pongs = node.create_subscription('std_msgs/msg/Float64', '/' + pong_key, qos=100)
        ping = node.create_publisher('std_msgs/msg/Float64', '/' + ping_key)
        ping.wait_for_subscribers(30)
        close = node.transport.close

        def round_trip() -> float:
            message.data += 1.0
            start = time.perf_counter()
            ping.write(message)
            pongs.wait_for_message(2)
            return time.perf_counter() - start

    for _ in range(WARM_UP):
        round_trip()
    print('ready', flush=True)
    for line in sys.stdin:
        print(json.dumps([round_trip() for _ in range(int(line))]), flush=True)
    close()


# --- the driver's side --------------------------------------------------------------------------


def spawn_role(
    role: str,
    impl: str,
    endpoint: str,
    extra: list[str],
    shm: bool,
    *,
    peer: bool = False,
    stdin: int | None = None,
) -> subprocess.Popen[str]:
    """``transport.py`` in another process, playing ``role`` (``<impl>@before``: with zros
    imported from the checkout :data:`against` names)."""
    env = None
    if impl.endswith(BEFORE):
        assert against is not None, 'an @before competitor needs transport.py --against'
        impl = impl.removesuffix(BEFORE)
        env = {**os.environ, 'PYTHONPATH': against}
    command = [sys.executable, SCRIPT, '--role', role, '--impl', impl, '--endpoint', endpoint]
    command += extra
    if shm:
        command.append('--shm')
    if peer:
        command.append('--peer')
    return subprocess.Popen(command, stdin=stdin, stdout=subprocess.PIPE, text=True, env=env)


def read_result(process: subprocess.Popen[str], timeout: float) -> dict[str, Any]:
    """The JSON line a role process printed last, once it ended."""
    out, _ = process.communicate(timeout=timeout)
    lines = [line for line in out.splitlines() if line.startswith('{')]
    if process.returncode != 0 or not lines:
        raise RuntimeError(f'a benchmark process failed (exit {process.returncode}): {out[-500:]}')
    return dict(json.loads(lines[-1]))


def twin(impl: str) -> str:
    """A competitor's name run from the ``--against`` checkout (a zros one), else the name."""
    return impl + BEFORE if impl.startswith('zros') else impl


def send_turn(process: subprocess.Popen[str], count: int) -> None:
    """Tell a role process taking turns to do ``count`` (messages, round trips)."""
    assert process.stdin is not None
    process.stdin.write(f'{count}\n')
    process.stdin.flush()


def publish_turn(
    publisher: subprocess.Popen[str], subscriber: subprocess.Popen[str], count: int
) -> dict[str, Any]:
    """One turn of a publisher and a subscriber taking turns (``--turns``): ``count`` messages;
    the subscriber's line, with the publisher's CPU seconds (``cpu_publisher``) and the
    router's (``cpu_router``: this process's, where the driver runs the router)."""
    router = time.process_time()
    send_turn(publisher, count)
    found: dict[str, Any] = read_line(subscriber)
    found['cpu_publisher'] = read_line(publisher)['cpu']
    found['cpu_router'] = time.process_time() - router
    return found


def read_line(process: subprocess.Popen[str]) -> Any:
    """The next JSON line a role process prints."""
    assert process.stdout is not None
    return json.loads(process.stdout.readline())


def end_roles(processes: list[subprocess.Popen[str]]) -> None:
    """Kill role processes and close their pipes."""
    for process in processes:
        process.kill()
    for process in processes:
        process.wait()
        for stream in (process.stdin, process.stdout):
            if stream is not None:
                stream.close()


def total(turns: list[dict[str, Any]]) -> dict[str, Any]:
    """A competitor's turns as one run: the median turn's rate (a burst of load that hits one
    turn moves it little); messages and CPU added up."""
    result: dict[str, Any] = {'size': turns[0]['size']}
    for key in turns[0]:
        if key.startswith('cpu') or key in ('received', 'expected'):
            result[key] = sum(found[key] for found in turns)
    result['rate'] = statistics.median(found['rate'] for found in turns)
    return result


def wait_ready(process: subprocess.Popen[str]) -> None:
    """Wait until a role process printed ``ready``."""
    assert process.stdout is not None
    line = process.stdout.readline()
    if line.strip() != 'ready':
        raise RuntimeError(f'a benchmark process did not start: {line!r}')


ROLES = {'publish': role_publish, 'subscribe': role_subscribe, 'echo': role_echo, 'ping': role_ping}
