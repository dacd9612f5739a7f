"""Typed reading of a recording: messages as zros message classes, streamed."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from zros.bag.columns.extract import dataframe, extract, structured
from zros.bag.errors import BagError
from zros.bag.read.source import Connection, RawMessage, Source, open_source
from zros.bag.read.types import BagTypes
from zros.closing import Closing

if TYPE_CHECKING:
    import numpy as np

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
    nanoseconds = getattr(value, 'nanoseconds', value)
    if isinstance(nanoseconds, bool) or not isinstance(nanoseconds, int):
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
    """

    def __init__(self, path: str | Path, registry: TypeRegistry | None = None) -> None:
        self.source: Source = open_source(path)
        try:
            self.types = BagTypes(self.source.path, self.source.connections, registry)
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
        decode = self.types.decode
        for raw in self.raw_messages(topics, start, end):
            yield raw.connection.topic, raw.timestamp, decode(raw)

    def __iter__(self) -> Iterator[tuple[str, int, Message]]:
        return self.messages()

    # --- columns --------------------------------------------------------------------------

    def columns(
        self,
        topic: str,
        fields: Iterable[str] | None = None,
        start: TimeLike = None,
        end: TimeLike = None,
    ) -> dict[str, np.ndarray]:
        """Numeric fields of a topic's messages as numpy arrays, one per field path.

        ``fields`` are paths such as ``pose.pose.position.x`` (default: every numeric field).
        The ``time`` column holds the receive times (int64 ns). Arrays of fixed length, and
        sequences whose length is the same in every message, become 2-D arrays; other sequences
        become object arrays of 1-D arrays.
        """
        connections = self._connections([topic])
        return extract(
            self.source,
            self.types,
            connections,
            fields,
            start=_nanoseconds(start),
            end=_nanoseconds(end),
        )

    def to_numpy(
        self,
        topic: str,
        fields: Iterable[str] | None = None,
        start: TimeLike = None,
        end: TimeLike = None,
    ) -> np.ndarray:
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

    # --- lifetime -------------------------------------------------------------------------

    def close(self) -> None:
        """Close the recording's files."""
        self.source.close()

    def __repr__(self) -> str:
        return f'<Bag {self.path}: {len(self.topics)} topics, {self.message_count} messages>'
