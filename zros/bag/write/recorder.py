"""Record live topics into a rosbag2 MCAP bag, as ``ros2 bag record`` does.

Topics are found in the graph as publishers announce them, also after recording started (with
``all`` or a ``regex``). Each one gets a raw Zenoh subscription (announced like a zros
subscriber) whose callback only stamps the receive time and queues the sample; one writer thread
appends the CDR bytes to the bag as they came, never decoding them. The callbacks never wait: a
waiting callback would stall every subscription and query of the session (the recorder's node
answers parameter queries too). Past its bounds the queue drops new messages, counted in
``Recorder.dropped`` and logged, as rosbag2 drops when its cache is full.
"""

from __future__ import annotations

import collections
import logging
import os
import re
import threading
import time
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

from zros.api import default_node
from zros.bag.errors import RecorderError
from zros.bag.read.outages import OUTAGES_KEY, LinkOutage, outages_text
from zros.bag.write.bag_writer import BagTopic, BagWriter
from zros.bag.write.mcap_writer import DEFAULT_CHUNK_SIZE
from zros.closing import Closing
from zros.pubsub.taps import RawTap, graph_topics, is_hidden, matched_qos, publish_time
from zros.qos import QoS
from zros.runtime.drops import DropCounter
from zros.runtime.signal import Signal
from zros.version import counted

#: the recording QoS is the one matched to the publishers (kept under its old name)
recording_qos = matched_qos

if TYPE_CHECKING:
    from pathlib import Path

    import zenoh

    from zros.node import Node

_log = logging.getLogger('zros.bag')

#: unwritten messages (and bytes) the recorder holds; past either it drops new messages
MAX_QUEUE = 100_000
MAX_QUEUE_BYTES = 512 * 1024 * 1024
#: seconds between forced chunk flushes: at most this much is lost to a SIGKILL
FLUSH_INTERVAL = 1.0


class Recorder(Closing):
    """Records topics of the live graph into a bag folder (``ros2 bag record``).

    Choose ``topics`` (names), a ``regex`` (searched in names), or ``all``; with ``all`` or a
    regex, topics that appear later are recorded too, hidden ones (``/_x``) only with
    ``include_hidden``. ``split_size`` (bytes) and ``split_duration`` (seconds) split the bag
    into ``<name>_0.mcap``, ``<name>_1.mcap``...; ``compression`` is ``'zstd'``, ``'lz4'`` or
    None. Recording starts at once; :meth:`close` (or leaving a ``with`` block) writes the end
    of the last file and ``metadata.yaml``. ``on_topic(name, type)`` is called for every topic
    as its recording starts. ``node`` None uses the default node of ``zros.init``.

    Chunks are written when full (``chunk_size``) and at least every ``flush_interval``
    seconds, so a killed recorder leaves files readable up to their last chunk. When writing
    falls behind by ``max_queue`` messages or 512 MiB, new messages are dropped (``dropped``
    counts them, a warning names the topic) rather than stalling the node's session.
    """

    def __init__(
        self,
        node: Node | None,
        path: str | os.PathLike[str],
        topics: Iterable[str] | None = None,
        regex: str | None = None,
        all: bool = False,
        *,
        split_size: int | None = None,
        split_duration: float | None = None,
        compression: str | None = 'zstd',
        include_hidden: bool = False,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        flush_interval: float | None = FLUSH_INTERVAL,
        on_topic: Callable[[str, str], object] | None = None,
        max_queue: int = MAX_QUEUE,
    ) -> None:
        if node is None:
            node = default_node()
        node.context.check_open()
        self.node = node
        self._names = {node.resolve_name(name) for name in topics or ()}
        try:
            self._regex = re.compile(regex) if regex is not None else None
        except re.error as exc:
            raise RecorderError(f'the topic regex {regex!r} is invalid: {exc}') from None
        self._all = all
        if not (self._names or self._regex or all):
            raise RecorderError('nothing to record: give topic names, a regex, or all=True')
        if flush_interval is not None and not flush_interval > 0:
            raise RecorderError(f'flush_interval must be positive, got {flush_interval}')
        self._include_hidden = include_hidden
        self._on_topic = on_topic
        self._flush_interval = flush_interval
        self._max_queue = max(1, max_queue)
        self._bag = BagWriter(
            path,
            compression=compression,
            split_size=split_size,
            split_duration=split_duration,
            chunk_size=chunk_size,
            ros_distro=node.registry.distro,
        )
        self.path: Path = self._bag.path
        self._sim = node.use_sim_time
        self._lock = threading.Lock()  # guards the queue, and taps against close
        self._queue: collections.deque[tuple[int, int, zenoh.Sample, int]] = collections.deque()
        self._queued_bytes = 0
        self._arrived = Signal()
        self._topic_list: list[BagTopic] = []  #: in recording order (the bag adds them so)
        self._types: dict[str, str] = {}
        self._taps: list[RawTap] = []
        self._started = Signal()  #: a topic started recording
        self._stopping = False  #: no new taps, callbacks drop
        self._draining = False  #: the writer thread finishes the queue and ends
        self._closed = False
        self.error: BaseException | None = None  #: what stopped the writer thread, if anything
        self.message_count = 0  #: messages written so far
        self.received = 0  #: messages that reached the recorder (written, queued or dropped)
        self.dropped = 0  #: messages lost because the queue was full (the disk fell behind)
        self.size = 0  #: bytes written so far (the open chunk counted uncompressed)
        self._began_ns = time.time_ns()
        self._ended_ns: int | None = None
        self._writer = threading.Thread(target=self._write_loop, name='zros recorder', daemon=True)
        self._writer.start()
        self._discovery = threading.Thread(
            target=self._discover_loop, name='zros recorder discovery', daemon=True
        )
        self._discovery.start()

    # --- what to record ------------------------------------------------------------------------

    def _wanted(self, name: str) -> bool:
        if name in self._names:
            return True
        if not self._include_hidden and is_hidden(name):
            return False
        return self._all or (self._regex is not None and self._regex.search(name) is not None)

    def _discover_loop(self) -> None:
        graph = self.node.graph
        while not self._stopping:
            seen = graph.version
            try:
                self._discover()
            except Exception:  # the discovery thread outlives a bad graph entry, a closing session
                _log.exception('the recorder failed to look at the graph')
            graph.wait_until(self._graph_changed(seen), 0.1, interruptible=False)

    def _graph_changed(self, seen: int) -> Callable[[], bool]:
        graph = self.node.graph
        return lambda: graph.version != seen or self._stopping

    def _discover(self) -> None:
        for name, topic in graph_topics(self.node).items():
            if name in self._types or not self._wanted(name):
                continue
            self._start(name, topic.type_name, topic.offered, topic.key)

    def _start(self, name: str, type_name: str, offered: list[QoS], key: str | None) -> None:
        topic = BagTopic.from_registry(self.node.registry, name, type_name, offered)
        with self._lock:
            if self._stopping:
                return
            index = len(self._topic_list)
            self._topic_list.append(topic)
            self._types[name] = type_name
            tap = RawTap(
                self.node,
                name,
                type_name,
                qos=matched_qos(offered),
                key=key,
                callback=self._callback(index, name),
            )
            self._taps.append(tap)
        _log.info('recording %s [%s]', name, type_name)
        if self._on_topic is not None:
            try:
                self._on_topic(name, type_name)
            except Exception:  # a user callback: logged
                _log.exception('on_topic callback %r raised', self._on_topic)
        self._started.notify()

    # --- on Zenoh's threads ---------------------------------------------------------------------

    def _callback(self, index: int, topic: str) -> Callable[[zenoh.Sample], None]:
        clock = self.node.clock
        now: Callable[[], int] = (lambda: clock.now().nanoseconds) if self._sim else time.time_ns
        queue = self._queue
        lock = self._lock
        arrived = self._arrived
        drops = DropCounter(topic)

        def on_sample(sample: zenoh.Sample) -> None:
            if self._stopping:
                return
            size = len(sample.payload)
            with lock:
                self.received += 1
                full = len(queue) >= self._max_queue or self._queued_bytes >= MAX_QUEUE_BYTES
                if full:
                    self.dropped += 1
                else:
                    queue.append((index, now(), sample, size))
                    self._queued_bytes += size
            if full:
                drops.add('queue', lambda: '', self._describe_full)
            elif arrived:
                arrived.notify()

        return on_sample

    def _describe_full(self) -> str:
        return (
            f'the recorder holds {len(self._queue)} unwritten messages, {self._queued_bytes} '
            f'bytes (at most {self._max_queue} and {MAX_QUEUE_BYTES}): {self.path} is not '
            'written fast enough'
        )

    # --- the writer thread ---------------------------------------------------------------------

    def _register_topics(self, done: int) -> int:
        """Add the topics found since (their messages may be queued); returns how many are."""
        while done < len(self._topic_list):
            self._bag.add_topic(self._topic_list[done])
            done += 1
        return done

    def _write_loop(self) -> None:
        bag = self._bag
        registered = 0
        last_flush = time.monotonic()
        interval = self._flush_interval
        described = 0  #: messages metadata.yaml counts

        def ready() -> bool:
            return bool(self._queue) or self._draining

        try:
            while True:
                wait = (
                    None if interval is None else max(0.0, last_flush + interval - time.monotonic())
                )
                self._arrived.wait(ready, wait)
                with self._lock:
                    batch = list(self._queue)
                    self._queue.clear()
                    self._queued_bytes = 0
                registered = self._register_topics(registered)
                for index, log_time, sample, _ in batch:
                    stamp = log_time if self._sim else publish_time(sample, log_time)
                    bag.write(index, log_time, sample.payload.to_bytes(), stamp)
                self.message_count = bag.message_count
                if interval is not None and time.monotonic() - last_flush >= interval:
                    bag.flush()
                    noted = self._note_outages()
                    if noted or described != bag.message_count:  # for a killed recorder
                        bag.write_metadata()
                        described = bag.message_count
                    last_flush = time.monotonic()
                self.size = bag.size
                if self._draining and not self._queue:
                    self._register_topics(registered)
                    return
        except BaseException as exc:
            _log.exception('the recording to %s failed', self.path)
            self.error = exc
            self._stopping = True
            self._started.notify()

    def _note_outages(self) -> bool:
        """Put the outages so far into the bag's custom data; whether they changed (one going
        on counts up to now)."""
        outages = self.outages
        if not outages:
            return False
        text = outages_text(outages)
        changed = self._bag.custom_data.get(OUTAGES_KEY) != text
        self._bag.custom_data[OUTAGES_KEY] = text
        return changed

    # --- the user's side -----------------------------------------------------------------------

    @property
    def topics(self) -> dict[str, str]:
        """The topics being recorded and their types."""
        with self._lock:
            return dict(self._types)

    @property
    def outages(self) -> list[LinkOutage]:
        """When the node's session had no link to the router while recording (system time):
        messages published then are not in the bag. :meth:`close` stores them in the bag
        (:attr:`zros.bag.Bag.outages` reads them back)."""
        began = self._began_ns
        ended = time.time_ns() if self._ended_ns is None else self._ended_ns
        return [
            LinkOutage(max(start, began), min(ended if end is None else end, ended))
            for start, end in self.node.transport.outage_spans()
            if start < ended and (end is None or end > began)
        ]

    @property
    def files(self) -> list[Path]:
        """The bag's storage files so far."""
        return self._bag.files

    def wait_for_topics(self, names: Iterable[str] | int, timeout: float | None = 5.0) -> bool:
        """Wait until the named topics (or that many topics) are being recorded."""
        if isinstance(names, int):
            count = names

            def ready() -> bool:
                return len(self._types) >= count

        else:
            wanted = {self.node.resolve_name(name) for name in names}

            def ready() -> bool:
                return wanted <= self._types.keys()

        return self._started.wait_for(lambda: ready() or self._stopping, timeout) and ready()

    def close(self) -> None:
        """Stop recording, write what is queued, close the last file and write metadata.yaml.

        Raises RecorderError if writing failed during the recording.
        """
        if self._closed:
            return
        self._closed = True
        with self._lock:
            self._stopping = True
            taps, self._taps = self._taps, []
        for tap in taps:
            tap.close()
        self._draining = True
        self._arrived.notify()
        self._writer.join()
        self._discovery.join(2.0)
        self._started.notify()
        self._ended_ns = time.time_ns()
        self._note_outages()
        try:
            self._bag.close()
        except Exception as exc:  # whatever the storage writer raised becomes a RecorderError
            if self.error is None:
                raise RecorderError(f'cannot finish the bag {self.path}: {exc}') from exc
            _log.debug('closing the failed bag %s failed too', self.path, exc_info=True)
        finally:
            self.message_count = self._bag.message_count
            self.size = sum(path.stat().st_size for path in self._bag.files if path.exists())
        if self.error is not None:
            reason = f'the recording to {self.path} failed: {self.error}'
            raise RecorderError(reason) from self.error

    stop = close

    def __repr__(self) -> str:
        topics, messages = (
            counted(len(self._types), 'topic'),
            counted(self.message_count, 'message'),
        )
        return f'<zros Recorder {self.path} ({topics}, {messages})>'
