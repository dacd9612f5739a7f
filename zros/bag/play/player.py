"""Play a bag into the live graph, as ``ros2 bag play`` does.

Messages are published as the raw CDR bytes recorded, with their recorded spacing (divided by
``rate``): each is due at a time of a :class:`PlayClock` on the monotonic clock, and the player
sleeps until then (waking for pauses and steps). A reader thread reads ahead, so decompressing a
chunk never delays a message. Publishers take the QoS the recording offered (latched topics stay
latched); ``clock`` publishes ``/clock`` with the bag time for nodes using sim time.
"""

from __future__ import annotations

import logging
import os
import queue
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import TYPE_CHECKING

from zros.api import default_node
from zros.bag.errors import PlayerError
from zros.bag.play.play_clock import PlayClock
from zros.bag.play.play_topics import (
    is_service_event,
    message_class,
    parse_remap,
    playback_qos,
)
from zros.bag.read.rosbag2_yaml import parse_qos_profiles
from zros.bag.read.source import open_source
from zros.cdr.message import Message
from zros.cdr.registry import registry_of
from zros.closing import Closing
from zros.errors import ZrosError
from zros.pubsub import Publisher
from zros.qos import QoS, Reliability
from zros.runtime.signal import add_interrupt_listener, remove_interrupt_listener
from zros.services.typeinfo import TypeDescriptionService
from zros.version import counted

if TYPE_CHECKING:
    from zros.bag.read.source import Connection, RawMessage, Source
    from zros.node import Node

_log = logging.getLogger('zros.bag')
_NS = 1_000_000_000
#: ``ros2 bag play --clock`` without a frequency
DEFAULT_CLOCK_HZ = 40.0
#: read-ahead: batches of up to this many messages or bytes, this many batches at most
_BATCH_MESSAGES = 256
_BATCH_BYTES = 1 << 20
_BATCHES = 32
_LOOP = None  #: the reader's marker between two passes of a looping playback


class Player(Closing):
    """Publishes the messages of a bag with their recorded timing (``ros2 bag play``).

    ``rate`` scales the speed, ``start_offset`` skips seconds from the start, ``loop`` plays
    again and again, ``topics`` selects topics, ``remap`` renames them (``{'/a': '/b'}`` or
    ``['/a:=/b']``), ``clock`` publishes ``/clock`` (True: 40 Hz, or a frequency).
    ``wait_for_subscribers`` waits up to that many seconds, before the first message, for
    every topic to have a subscriber (messages put before a subscriber is matched are lost).

    :meth:`play` plays in the calling thread; :meth:`start` in a thread of its own. While it
    plays, :meth:`pause`, :meth:`resume`, :meth:`step` (publish the next message while paused),
    :meth:`set_rate` and :meth:`stop` steer it from any thread.
    """

    def __init__(
        self,
        node: Node | None,
        path: str | os.PathLike[str],
        *,
        rate: float = 1.0,
        start_offset: float = 0.0,
        loop: bool = False,
        topics: Iterable[str] | None = None,
        remap: Mapping[str, str] | Iterable[str] | None = None,
        clock: bool | float = False,
        wait_for_subscribers: float = 0.0,
        on_message: Callable[[RawMessage], object] | None = None,
    ) -> None:
        if node is None:
            node = default_node()
        node.context.check_open()
        if not rate > 0:
            raise PlayerError(f'the rate must be positive, got {rate}')
        if not start_offset >= 0:
            raise PlayerError(f'the start offset must be 0 or more seconds, got {start_offset}')
        hz = DEFAULT_CLOCK_HZ if clock is True else float(clock)
        if clock is not False and not hz > 0:
            raise PlayerError(f'the /clock frequency must be positive, got {clock}')
        self.node = node
        self.rate = rate
        self.loop = loop
        self._clock_hz = hz if clock is not False else None
        self._wait = wait_for_subscribers
        self._on_message = on_message
        self.source: Source = open_source(os.fspath(path))
        try:
            self._setup(topics, parse_remap(remap), start_offset)
        except BaseException:
            self.source.close()
            raise
        self._stopped = threading.Event()
        self._done = threading.Event()
        self._step = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None
        self.published = 0  #: messages published so far
        self.position_ns = self.start_ns  #: bag time of the last message published
        self.loops = 0  #: passes completed

    def _setup(
        self, topics: Iterable[str] | None, remap: dict[str, str], start_offset: float
    ) -> None:
        source = self.source
        connections = list(source.connections)
        remap = {self._full_name(old): new for old, new in remap.items()}
        if topics is not None:
            name = self._full_name  # 'chatter' in a bag is '/chatter' on the network
            wanted = {name(t) for t in topics}
            missing = wanted - {name(c.topic) for c in connections}
            if missing:
                raise PlayerError(
                    f'the bag {source.path} has no topic {", ".join(sorted(missing))}; it has '
                    f'{", ".join(sorted({name(c.topic) for c in connections}))}'
                )
            connections = [c for c in connections if name(c.topic) in wanted]
        events = sorted({c.topic for c in connections if is_service_event(c)})
        if events and topics is not None:  # named: an error; else left out, and told
            raise PlayerError(
                f'cannot play {", ".join(events)}: zros does not play service events '
                f'(recorded service calls); leave {"them" if len(events) > 1 else "it"} '
                'out of the topics'
            )
        if events:
            _log.warning(
                'not playing %s: zros does not play service events (recorded service calls)',
                ', '.join(events),
            )
            connections = [c for c in connections if not is_service_event(c)]
        self.start_ns = source.start_ns + round(start_offset * _NS)
        self.end_ns = source.end_ns
        self._publishers: dict[int, Publisher[Message]] = {}
        by_topic: dict[tuple[str, str], Publisher[Message]] = {}

        playable: list[Connection] = []
        unplayable: list[PlayerError] = []
        for connection in connections:
            full = self._full_name(connection.topic)
            target = remap.get(full, full)
            key = (target, connection.type_name)
            publisher = by_topic.get(key)
            if publisher is None:
                try:
                    offered = parse_qos_profiles(connection.qos)
                except ValueError as exc:
                    _log.warning('%s: %s; publishing with the default QoS', connection.topic, exc)
                    offered = []
                try:
                    cls = message_class(self.node, connection)
                except PlayerError as exc:
                    unplayable.append(exc)
                    continue
                publisher = Publisher(target, cls, playback_qos(offered), node=self.node)
                by_topic[key] = publisher
            self._publishers[connection.id] = publisher
            playable.append(connection)
        if unplayable and not playable:
            raise unplayable[0]
        for problem in unplayable:
            _log.warning('%s; playing the other topics', problem)
        self.connections = playable
        self.topics = {p.topic: p.type_name for p in by_topic.values()}
        self._describe_bag_types(list(by_topic.values()))
        self._clock_publisher: Publisher[Message] | None = None
        if self._clock_hz is not None:
            self._clock_publisher = Publisher(
                '/clock', 'rosgraph_msgs/msg/Clock', QoS(1, Reliability.BEST_EFFORT),
                node=self.node,
            )  # fmt: skip
            self._clock_msg = self._clock_publisher.msg_type()
        self.clock = PlayClock(self.start_ns, self.rate)
        self.clock.pause()

    def _describe_bag_types(self, publishers: list[Publisher[Message]]) -> None:
        """Serve ``~/get_type_description`` for the types only the bag defines, as ROS 2 nodes
        serve their types: ``zros topic echo`` (and ROS tools) learn them from the player."""
        self._types: TypeDescriptionService | None = None
        own = [p.msg_type for p in publishers if registry_of(p.msg_type) is not self.node.registry]
        if own and self.node.context.type_used is None:  # else the node serves them already
            self._types = TypeDescriptionService(self.node)
            for cls in own:
                self._types.add(cls)

    def _full_name(self, name: str) -> str:
        try:
            return self.node.resolve_name(name)
        except ZrosError:  # not a valid ROS name: left for the publisher to refuse
            return name

    # --- reading ahead -------------------------------------------------------------------------

    def _read_ahead(self, batches: queue.Queue[list[RawMessage] | None]) -> None:
        def put(item: list[RawMessage] | None) -> bool:
            while not self._stopped.is_set():
                try:
                    batches.put(item, timeout=0.1)
                    return True
                except queue.Full:
                    continue
            return False

        try:
            while True:
                batch: list[RawMessage] = []
                size = count = 0
                for message in self.source.messages(self.connections, start=self.start_ns):
                    batch.append(message)
                    size += len(message.data)
                    count += 1
                    if len(batch) >= _BATCH_MESSAGES or size >= _BATCH_BYTES:
                        if not put(batch):
                            return
                        batch, size = [], 0
                if batch and not put(batch):
                    return
                if not (self.loop and count) or not put(_LOOP):
                    break
        except BaseException as exc:
            self.error = exc
        finally:
            put([])  # the end

    def _messages(self) -> Iterator[RawMessage | None]:
        batches: queue.Queue[list[RawMessage] | None] = queue.Queue(_BATCHES)
        reader = threading.Thread(
            target=self._read_ahead, args=(batches,), name='zros player reader', daemon=True
        )
        reader.start()
        try:
            while not self._stopped.is_set():
                try:
                    # a stop can come between the check above and this get, and the reader
                    # then ends without the end marker: never block for good
                    batch = batches.get(timeout=0.1)
                except queue.Empty:
                    continue
                if batch is _LOOP:
                    yield None
                    continue
                if not batch:
                    return
                yield from batch
        finally:
            self._stopped.set()
            while reader.is_alive():
                try:
                    batches.get_nowait()
                except queue.Empty:
                    reader.join(0.05)

    # --- /clock --------------------------------------------------------------------------------

    def _publish_clock(self) -> None:
        publisher = self._clock_publisher
        if publisher is None:
            return
        message = self._clock_msg
        message.clock.sec, message.clock.nanosec = divmod(self.clock.now(), _NS)
        publisher.write(message)

    def _clock_loop(self) -> None:
        assert self._clock_hz is not None
        period = 1.0 / self._clock_hz
        next_due = time.monotonic()
        while not self._done.is_set():
            self._publish_clock()
            next_due += period
            now = time.monotonic()
            if next_due < now:  # fell behind: skip the missed ticks
                next_due = now + period
            self._done.wait(next_due - now)

    # --- playing -------------------------------------------------------------------------------

    def wait_for_subscribers(self, timeout: float) -> bool:
        """Wait until every topic's publisher has a subscriber; whether they all do."""
        deadline = time.monotonic() + timeout
        publishers = set(self._publishers.values())
        while not all(p.has_subscribers for p in publishers):
            if time.monotonic() >= deadline or self._stopped.is_set():
                return False
            self._stopped.wait(0.005)
        return True

    def play(self) -> None:
        """Play the bag (every pass, if looping) in this thread; returns when done or stopped
        (Ctrl-C after ``zros.init`` stops it).

        Raises the reading error, if the bag turned out unreadable on the way.
        """
        clock_thread = None
        add_interrupt_listener(self.stop)
        try:
            if self._wait > 0:
                self.wait_for_subscribers(self._wait)
            self.clock.jump(self.start_ns)
            if self._clock_hz is not None:
                self._publish_clock()
                clock_thread = threading.Thread(
                    target=self._clock_loop, name='zros player clock', daemon=True
                )
                clock_thread.start()
            if not self._stepping_pause:
                self.clock.resume()
            self._run()
        finally:
            remove_interrupt_listener(self.stop)
            self._done.set()
            if clock_thread is not None:
                clock_thread.join()
                self._publish_clock()  # the final time
        if self.error is not None:
            raise PlayerError(f'playing {self.source.path} failed: {self.error}') from self.error

    _stepping_pause = False  #: start paused (``start(paused=True)``)

    def _run(self) -> None:
        clock = self.clock
        publishers = self._publishers
        stopped = self._stopped.is_set
        for message in self._messages():
            if message is None:  # the next pass of a loop
                self.loops += 1
                clock.jump(self.start_ns)
                continue
            if self._step.is_set():
                self._step.clear()
                clock.jump(message.timestamp)
            elif not clock.sleep_until(message.timestamp, self._should_wake):
                if stopped():
                    return
                # woken for a step while paused
                self._step.clear()
                clock.jump(message.timestamp)
            data = message.data
            publishers[message.connection.id].write_raw(
                data if isinstance(data, bytes) else bytes(data)
            )
            self.published += 1
            self.position_ns = message.timestamp
            if self._on_message is not None:
                self._on_message(message)
        if not stopped():
            self.loops += 1

    def _should_wake(self) -> bool:
        return self._stopped.is_set() or self._step.is_set()

    def start(self, paused: bool = False) -> None:
        """Play in a background thread (``wait()`` for the end)."""
        if self._thread is not None:
            raise PlayerError('this player was started already')
        self._stepping_pause = paused

        def run() -> None:
            try:
                self.play()
            except PlayerError:
                _log.exception('playback failed')

        self._thread = threading.Thread(target=run, name='zros player', daemon=True)
        self._thread.start()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait until the playback ends (Ctrl-C ends it); whether it did."""
        return self._done.wait(timeout)

    @property
    def done(self) -> bool:
        """Whether playing has finished (or was stopped)."""
        return self._done.is_set()

    @property
    def paused(self) -> bool:
        """Whether playing is paused."""
        return self.clock.paused

    def pause(self) -> None:
        """Pause playing; :meth:`resume` continues where it stopped."""
        self.clock.pause()

    def resume(self) -> None:
        """Continue playing after :meth:`pause`."""
        self.clock.resume()

    def toggle_pause(self) -> None:
        """Pause if playing, resume if paused."""
        if self.clock.paused:
            self.clock.resume()
        else:
            self.clock.pause()

    def step(self) -> None:
        """While paused, publish the next message now (the bag time jumps to it)."""
        if self.clock.paused:
            self._step.set()
            self.clock.interrupt()

    def set_rate(self, rate: float) -> None:
        """Change the playing speed (1.0: as recorded)."""
        self.clock.set_rate(rate)
        self.rate = rate

    def stop(self) -> None:
        """Stop playing (from any thread); :meth:`close` releases the publishers."""
        self._stopped.set()
        self.clock.interrupt()

    def close(self) -> None:
        """Stop, wait for the player thread, close the publishers and the bag."""
        self.stop()
        if self._thread is not None:
            self._thread.join()
        for publisher in {*self._publishers.values(), self._clock_publisher}:
            if publisher is not None:
                publisher.close()
        if self._types is not None:
            self._types.close()
        self.source.close()

    def __repr__(self) -> str:
        topics = counted(len(self.topics), 'topic')
        return f'<zros Player {self.source.path} ({topics}, rate {self.rate})>'
