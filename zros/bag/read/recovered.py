"""What the readers of damaged or unfinished files share with rosbags' storage readers."""

from __future__ import annotations

from collections.abc import Collection, Iterator
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rosbags.interfaces import Connection


class Recovered:
    """A storage read around its damage (``connections`` set by its ``open``), with the
    ``messages`` of rosbags' readers."""

    connections: list[Connection]

    def messages(
        self,
        connections: Collection[Connection] = (),
        start: int | None = None,
        stop: int | None = None,
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """(connection, time, data) of ``connections`` (default all) with ``start <= time <
        stop``, in time order."""
        by_id = {c.id: c for c in connections or self.connections}
        return self._select(by_id, start, stop)

    def _select(
        self, by_id: dict[int, Connection], start: int | None, stop: int | None
    ) -> Iterator[tuple[Connection, int, bytes]]:
        raise NotImplementedError


def within(stamp: int, start: int | None, stop: int | None) -> bool:
    """Whether ``start <= stamp < stop`` (None: unbounded)."""
    return (start is None or stamp >= start) and (stop is None or stamp < stop)
