"""Typed reading of a recording: messages as zros message classes, streamed."""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from zros.bag.columns.addresses import column_series, series_columns
from zros.bag.columns.align import Columns, align
from zros.bag.columns.extract import dataframe, extract, structured
from zros.bag.errors import BagError
from zros.bag.read.damage import Skipped
from zros.bag.read.outages import LinkOutage, read_outages
from zros.bag.read.source import Connection, RawMessage, Source, open_source
from zros.bag.read.types import BagTypes
from zros.cdr.arrays import Array
from zros.closing import Closing
from zros.timesync import ApproximatePolicy, header_stamp, integer_ns
from zros.version import counted

if TYPE_CHECKING:
    from zros.bag.columns.extract import DataFrame
    from zros.cdr import Message, TypeRegistry


class HasNanoseconds(Protocol):
    """A time as an object with integer ``nanoseconds`` (``zros.Time``)."""

    @property
    def nanoseconds(self) -> int:
        """The time in integer nanoseconds."""


#: a time bound: integer nanoseconds, or an object with ``nanoseconds`` (zros.Time)
TimeLike = int | HasNanoseconds | None


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a recording: its type, message count and connections."""

    name: str
    type_name: str
    count: int
    connections: tuple[Connection, ...]


def _nanoseconds(value: TimeLike) -> int | None:
    if value is None:
        return None
    nanoseconds = integer_ns(getattr(value, 'nanoseconds', value))
    if nanoseconds is None:
        raise TypeError(
            f'a time bound is integer nanoseconds or a zros.Time, not {type(value).__name__}'
        )
    return nanoseconds


class Bag(Closing):
    """A recording opened for reading (a context manager).

    >>> with Bag('my_bag') as bag:                                 # doctest: +SKIP
    ...     for topic, stamp, message in bag.messages(['/odom']):
    ...         print(stamp, message.pose.pose.position.x)

    ``registry`` is the type registry consulted for types the recording does not define
    (default: the process-wide one).

    A damaged part (a chunk or row that does not decompress, parse or decode) is skipped with a
    warning and listed in :attr:`skipped`; everything else is read. ``strict=True`` raises
    :class:`BagError` on it instead.
    """

    def __init__(
        self, path: str | Path, registry: TypeRegistry | None = None, *, strict: bool = False
    ) -> None:
        self.source: Source = open_source(path, strict)
        try:
            self.types = BagTypes(
                self.source.path,
                self.source.connections,
                registry,
                self.source.damage,
                self.source.locate,
            )
        except BaseException:
            self.source.close()
            raise

    # --- what the recording holds ---------------------------------------------------------

    @property
    def path(self) -> Path:
        """The recording's path."""
        return self.source.path

    @property
    def connections(self) -> list[Connection]:
        """The recording's connections (topic, type, QoS...), as stored."""
        return self.source.connections

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """Topic name -> :class:`TopicInfo`, in the order the recording lists them."""
        grouped: dict[str, list[Connection]] = {}
        for connection in self.connections:
            grouped.setdefault(connection.topic, []).append(connection)
        return {
            name: TopicInfo(
                name,
                group[0].type_name,
                sum(c.count for c in group),
                tuple(group),
            )
            for name, group in grouped.items()
        }

    @property
    def start_ns(self) -> int:
        """Receive time of the first message (0 without messages)."""
        return self.source.start_ns

    @property
    def end_ns(self) -> int:
        """Receive time of the last message (0 without messages)."""
        return self.source.end_ns

    @property
    def duration_ns(self) -> int:
        """Nanoseconds from the first message to the last."""
        return self.source.duration_ns

    @property
    def message_count(self) -> int:
        """How many messages the recording holds."""
        return self.source.message_count

    @property
    def skipped(self) -> list[Skipped]:
        """What damage cost so far: a :class:`~zros.bag.read.damage.Skipped` per damaged unit
        and topic (file, byte offset or row, topic, messages lost, reason), in the order met."""
        return list(self.source.damage.skipped)

    @property
    def custom_data(self) -> dict[str, str]:
        """rosbag2's ``custom_data`` of the recording (empty where it has none)."""
        return dict(self.source.custom_data)

    @property
    def outages(self) -> list[LinkOutage]:
        """When ``zros bag record`` had no link to the router, in system time: messages
        published then are missing (a gap there is not the robot falling silent)."""
        return read_outages(self.source.custom_data, self.path)

    def message_class(self, topic: str) -> type[Message]:
        """The class the messages of ``topic`` decode to."""
        return self.types.message_class(self._connections([topic])[0])

    # --- messages -------------------------------------------------------------------------

    def _connections(self, topics: str | Iterable[str] | None) -> list[Connection]:
        if topics is None:
            return list(self.connections)
        wanted = [topics] if isinstance(topics, str) else list(topics)
        known = self.topics
        missing = [t for t in wanted if t not in known]
        if missing:
            raise BagError(
                self.path,
                f'no topic {missing[0]} in the recording; it has: {", ".join(known) or "none"}',
            )
        return [c for c in self.connections if c.topic in wanted]

    def raw_messages(
        self,
        topics: str | Iterable[str] | None = None,
        start: TimeLike = None,
        end: TimeLike = None,
    ) -> Iterator[RawMessage]:
        """The undecoded messages of ``topics`` with ``start <= time < end``, in time order."""
        return self.source.messages(
            self._connections(topics), _nanoseconds(start), _nanoseconds(end)
        )

    def messages(
        self,
        topics: str | Iterable[str] | None = None,
        start: TimeLike = None,
        end: TimeLike = None,
    ) -> Iterator[tuple[str, int, Message]]:
        """``(topic, receive time in ns, message)`` for each message, in time order.

        ``start`` and ``end`` bound the receive time (``start <= time < end``), in integer
        nanoseconds or as ``zros.Time``. Messages are decoded as the iteration reaches them.
        """
        decode = self.types.decode_or_skip
        for raw in self.raw_messages(topics, start, end):
            message = decode(raw)
            if message is not None:
                yield raw.connection.topic, raw.timestamp, message

    def __iter__(self) -> Iterator[tuple[str, int, Message]]:
        return self.messages()

    # --- columns --------------------------------------------------------------------------

    def columns(
        self,
        topic: str,
        fields: Iterable[str] | None = None,
        start: TimeLike = None,
        end: TimeLike = None,
    ) -> dict[str, Array]:
        """Numeric fields of a topic's messages as numpy arrays, one per field path.

        ``fields`` are paths such as ``pose.pose.position.x`` (default: every numeric field).
        The ``time`` column holds the receive times (int64 ns). Arrays of fixed length, and
        sequences whose length is the same in every message, become 2-D arrays; other sequences
        become object arrays of 1-D arrays. ``zros plot``'s addresses work too: a whole address
        as ``topic`` (``'/odom/pose/pose/position/x'``), or fields with slashes
        (``'pose/pose/position/x'``); an element (``'position[0]'`` or ``'position/0'``) is the
        column ``position[0]``.
        """
        fields = None if fields is None else list(fields)  # read twice
        topic_types = {name: info.type_name for name, info in self.topics.items()}
        topic, plain, series = column_series(
            topic, fields, topic_types, lambda name, _: self.message_class(name), self.path.name
        )
        found = extract(
            self.source,
            self.types,
            self._connections([topic]),
            plain,
            start=_nanoseconds(start),
            end=_nanoseconds(end),
        )
        if not series:
            return found
        return series_columns(found, series, list(fields or ()))

    def to_numpy(
        self,
        topic: str,
        fields: Iterable[str] | None = None,
        start: TimeLike = None,
        end: TimeLike = None,
    ) -> Array:
        """The :meth:`columns` of a topic as one numpy structured array (a record per message)."""
        return structured(self.columns(topic, fields, start, end), self.path)

    def to_dataframe(
        self,
        topic: str,
        fields: Iterable[str] | None = None,
        start: TimeLike = None,
        end: TimeLike = None,
    ) -> DataFrame:
        """The :meth:`columns` of a topic as a pandas DataFrame (pandas must be installed).

        2-D columns are spread over ``name[0]``, ``name[1]``...; ``time`` is a column of int64 ns.
        """
        return dataframe(self.columns(topic, fields, start, end))

    # --- topics on one clock -----------------------------------------------------------------

    def align(
        self,
        columns: Columns,
        on: str | float,
        *,
        method: str = 'nearest',
        tolerance: float | None = None,
        stamp: str = 'header',
        as_dataframe: bool = False,
    ) -> Array | DataFrame:
        """Fields of several topics in one table, a row per instant of ``on``.

        ``columns`` names topics and fields as ``'/imu'`` (every numeric field) or
        ``'/imu.linear_acceleration'`` (a field, or a struct's fields), in a list, or as a
        mapping ``{'/imu': ['linear_acceleration.x'], '/odom': None}``. ``on`` is a topic (its
        messages' stamps are the rows) or a period in seconds (from the first stamp to the
        last). ``method`` is ``'nearest'``, ``'previous'`` or ``'linear'``; a match farther
        than ``tolerance`` seconds leaves NaN. ``stamp`` is ``'header'`` (``header.stamp``;
        topics without one use their receive time, with a warning) or ``'receive'``. The
        result is a numpy structured array (``time``, int64 ns, then ``topic.field``, float64),
        or a pandas DataFrame with ``as_dataframe``. See docs/bags.md for the rules.
        """
        columns_ = align(
            self.path, self.columns, self.message_class, columns,
            on=on, method=method, tolerance=tolerance, stamp=stamp,
        )  # fmt: skip
        return dataframe(columns_) if as_dataframe else structured(columns_, self.path)

    def synchronize(
        self,
        topics: Iterable[str],
        slop: float,
        queue_size: int = 10,
        allow_headerless: bool = False,
    ) -> Iterator[tuple[Message, ...]]:
        """Sets of one message per topic whose header stamps lie less than ``slop`` seconds
        apart, matched as ``zros.message_filters.ApproximateTimeSynchronizer`` matches live
        messages (fed in receive order). Messages without a header are skipped with a
        warning, or with ``allow_headerless`` stamped with their receive time."""
        order = list(topics)
        if len(set(order)) != len(order):
            raise ValueError(f'each topic once, please: {", ".join(order)}')
        self._connections(order)  # an unknown topic fails here, not at the first next()
        policy: ApproximatePolicy[Message] = ApproximatePolicy(
            len(order), queue_size, round(slop * 1_000_000_000)
        )
        return self._synchronized(order, policy, allow_headerless)

    def _synchronized(
        self, order: list[str], policy: ApproximatePolicy[Message], allow_headerless: bool
    ) -> Iterator[tuple[Message, ...]]:
        index = {topic: i for i, topic in enumerate(order)}
        warned: set[str] = set()
        for topic, received, message in self.messages(order):
            stamp = header_stamp(message)
            if stamp is None:
                if not allow_headerless:
                    if topic not in warned:
                        warned.add(topic)
                        warnings.warn(
                            f'synchronize: {topic} has no header stamp; its messages are '
                            'skipped (allow_headerless=True uses their receive times)',
                            stacklevel=2,
                        )
                    continue
                stamp = received
            yield from policy.add(index[topic], stamp, message)

    # --- lifetime -------------------------------------------------------------------------

    def close(self) -> None:
        """Close the recording's files."""
        self.source.close()

    def __repr__(self) -> str:
        topics, messages = (
            counted(len(self.topics), 'topic'),
            counted(self.message_count, 'message'),
        )
        return f'<Bag {self.path}: {topics}, {messages}>'
