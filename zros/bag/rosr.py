"""rosR's ``ros.BagRead``: a whole recording as four parallel columns."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.reader import Bag
from zros.cdr import Message

if TYPE_CHECKING:
    from zros.bag.reader import TimeLike


@dataclass
class BagRead:
    """Parallel columns, one row per message: ``topic``, ``data_type``, ``time_stamp`` (receive
    time, integer ns) and ``message``. ``read['topic']`` works too, as ``bag$topic`` in R."""

    topic: list[str] = field(default_factory=list)
    data_type: list[str] = field(default_factory=list)
    time_stamp: list[int] = field(default_factory=list)
    message: list[Message] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.topic)

    def __getitem__(self, column: str) -> list[str] | list[int] | list[Message]:
        if column not in ('topic', 'data_type', 'time_stamp', 'message'):
            raise KeyError(f'{column!r}; the columns are topic, data_type, time_stamp, message')
        values: list[str] | list[int] | list[Message] = getattr(self, column)
        return values

    def __iter__(self) -> Iterator[tuple[str, str, int, Message]]:
        """Rows: ``(topic, data_type, time_stamp, message)``."""
        return zip(self.topic, self.data_type, self.time_stamp, self.message, strict=True)


def bag_read(
    path: str | Path,
    topics: str | Iterable[str] | None = None,
    start: TimeLike = None,
    end: TimeLike = None,
    *,
    strict: bool = False,
) -> BagRead:
    """Read a recording's messages into memory (rosR: ``ros.BagRead(file, topics)``).

    ``topics`` selects topics (default all); ``start``/``end`` bound the receive time
    (``start <= time < end``, integer ns or ``zros.Time``). Damaged parts are skipped with a
    warning (``strict``: :class:`~zros.bag.BagError` instead), as :class:`~zros.bag.Bag` does.
    """
    result = BagRead()
    with Bag(path, strict=strict) as bag:
        for topic, stamp, message in bag.messages(topics, start, end):
            result.topic.append(topic)
            result.data_type.append(message.__msgtype__)
            result.time_stamp.append(stamp)
            result.message.append(message)
    return result
