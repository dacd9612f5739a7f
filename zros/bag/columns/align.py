"""Several topics' columns on one clock: a row per reference instant, vectorised with numpy.

Each topic is read once with ``Bag.columns``; its messages are put in stamp order (a stable
sort: out-of-order stamps are fine; of messages with the same stamp the last received counts)
and matched to the reference instants with ``searchsorted``:

* ``previous``: the newest message stamped at or before the instant;
* ``nearest``: the closest one, the earlier on a tie;
* ``linear``: the two around the instant, weighted by time (a message stamped at the instant
  is taken as it is). Bool fields cannot be interpolated: they take the nearest value and a
  warning names them.

A match farther than ``tolerance`` seconds from the instant (for ``linear``, either neighbour)
leaves NaN. Values are float64 (integers beyond 2**53 lose precision), so NaN can mark a miss.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from zros.bag.columns.extract import TIME
from zros.bag.columns.plan import Leaf, plan, select
from zros.bag.errors import BagError
from zros.cdr.arrays import Array

if TYPE_CHECKING:
    from zros.cdr.message import Message

METHODS = ('nearest', 'previous', 'linear')
STAMPS = ('header', 'receive')
_STAMP_FIELDS = ['header.stamp.sec', 'header.stamp.nanosec']
_NS = 1_000_000_000
#: the most rows a period grid may have (8 bytes a row for each column): larger is refused
MAX_GRID_ROWS = 100_000_000

#: what to align: ``'/imu'`` (every numeric field), ``'/imu.linear_acceleration'`` (a field or a
#: struct of fields), a list of those, or a mapping topic -> field paths (None: every field)
Columns = str | Iterable[str] | Mapping[str, str | Iterable[str] | None]
#: ``Bag.columns(topic, fields)``
ReadColumns = Callable[[str, list[str]], dict[str, Array]]


@dataclass
class _Topic:
    """One topic's columns as read, and the orders that put them on the clock."""

    columns: dict[str, Array]  #: as ``Bag.columns`` gave them (receive order)
    every: Array  #: every message's row, in stamp order (stable)
    every_stamp: Array  #: their stamps, int64 ns
    rows: Array  #: a row per distinct stamp: the last received
    stamps: Array  #: their stamps, increasing


def requested(columns: Columns) -> dict[str, list[str] | None]:
    """Topic -> field paths (None: every numeric field), in the order given."""
    wanted: dict[str, list[str] | None] = {}
    if isinstance(columns, Mapping):
        for topic, fields in columns.items():
            wanted[topic] = None if fields is None else _listed(fields)
        return wanted
    for name in [columns] if isinstance(columns, str) else columns:
        topic, dot, field = name.partition('.')  # ROS names have no dots: the first one ends it
        if not dot:
            wanted[topic] = None
            continue
        known = wanted.setdefault(topic, [])
        if known is not None:
            known.append(field)
    return wanted


def _listed(fields: str | Iterable[str]) -> list[str]:
    return [fields] if isinstance(fields, str) else list(fields)


def _period_ns(on: float) -> int:
    if isinstance(on, bool) or not isinstance(on, (int, float)):
        raise TypeError(f'on= is a topic name or a period in seconds, not {type(on).__name__}')
    period = round(on * _NS)
    if not period > 0:
        raise ValueError(f'the period on= must be positive, got {on} s')
    return period


def _check(method: str, stamp: str, tolerance: float | None) -> int | None:
    if method not in METHODS:
        raise ValueError(f'method is one of {", ".join(METHODS)}, not {method!r}')
    if stamp not in STAMPS:
        raise ValueError(f'stamp is one of {", ".join(STAMPS)}, not {stamp!r}')
    if tolerance is None:
        return None
    if not tolerance >= 0:
        raise ValueError(f'tolerance must be seconds >= 0, got {tolerance}')
    return round(tolerance * _NS)


class Aligner:
    """Reads the topics of one ``Bag.align`` call and matches them to the reference."""

    def __init__(
        self,
        path: Path,
        read: ReadColumns,
        message_class: Callable[[str], type[Message]],
        stamp: str,
    ) -> None:
        self.path = path
        self.read = read
        self.message_class = message_class
        self.stamp = stamp
        self.headerless: list[str] = []

    def leaves(self, topic: str, fields: list[str] | None) -> tuple[list[Leaf], bool]:
        """The leaves ``fields`` select, and whether the type has a header stamp."""
        cls = self.message_class(topic)
        plan_ = plan(cls)
        try:
            leaves = select(plan_, fields, cls.__msgtype__)
        except ValueError as exc:
            raise BagError(self.path, f'topic {topic}: {exc}') from None
        paths = {leaf.path for leaf in plan_.leaves}
        return leaves, all(p in paths for p in _STAMP_FIELDS)

    def topic(self, topic: str, fields: list[str] | None) -> tuple[list[Leaf], _Topic]:
        """Read ``topic``'s selected fields and put them in stamp order."""
        leaves, has_header = self.leaves(topic, fields)
        wanted = [leaf.path for leaf in leaves]
        use_header = self.stamp == 'header' and has_header
        if self.stamp == 'header' and not has_header:
            self.headerless.append(topic)
        extra = [p for p in _STAMP_FIELDS if use_header and p not in wanted]
        read = self.read(topic, wanted + extra)
        for name in wanted:
            if read[name].dtype == object:
                raise BagError(
                    self.path,
                    f'column {topic}.{name} holds sequences of different lengths, which cannot '
                    'be aligned; leave it out of the columns',
                )
        if use_header:
            stamps = read[_STAMP_FIELDS[0]].astype(np.int64) * _NS + read[_STAMP_FIELDS[1]]
        else:
            stamps = read[TIME]
        order = np.argsort(stamps, kind='stable')
        every = stamps[order]
        last = np.ones(len(every), bool)  # of equal stamps, the last received
        last[:-1] = every[1:] != every[:-1]
        return leaves, _Topic(read, order, every, order[last], every[last])


def _match(
    topic: _Topic, instants: Array, method: str, tolerance: int | None
) -> tuple[Array, Array, Array, Array]:
    """Per instant: the rows before and after (or the chosen row twice), the weight of the
    after row, and whether there is a match."""
    stamps = topic.stamps
    count = len(stamps)
    size = len(instants)
    if not count:
        zeros = np.zeros(size, np.intp)
        return zeros, zeros, np.zeros(size), np.zeros(size, bool)
    before = np.searchsorted(stamps, instants, 'right') - 1
    after = np.searchsorted(stamps, instants, 'left')
    has_before, has_after = before >= 0, after < count
    before_at = stamps[np.maximum(before, 0)]
    after_at = stamps[np.minimum(after, count - 1)]
    back = instants - before_at  # >= 0 where has_before
    ahead = after_at - instants  # >= 0 where has_after
    if method == 'linear':
        ok = has_before & has_after
        if tolerance is not None:
            ok &= (back <= tolerance) & (ahead <= tolerance)
        span = (after_at - before_at).astype(np.float64)
        weight = np.divide(back, span, out=np.zeros(size), where=span > 0)
        return np.maximum(before, 0), np.minimum(after, count - 1), weight, ok
    if method == 'previous':
        chosen, ok, distance = before, has_before, back
    else:
        take_before = has_before & (~has_after | (back <= ahead))
        chosen = np.where(take_before, before, after)
        ok = has_before | has_after
        distance = np.where(take_before, back, ahead)
    if tolerance is not None:
        ok &= distance <= tolerance
    chosen = np.clip(chosen, 0, count - 1)
    return chosen, chosen, np.zeros(size), ok


def _fill(
    column: Array,
    low: Array,
    high: Array,
    weight: Array,
    ok: Array,
    *,
    interpolate: bool,
) -> Array:
    size = len(ok)
    if not len(column):
        return np.full((size, *column.shape[1:]), np.nan)
    values: Array = column[low].astype(np.float64)
    if interpolate:
        w = weight.reshape(-1, *([1] * (column.ndim - 1)))
        values += (column[high].astype(np.float64) - values) * w
    values[~ok] = np.nan
    return values


def align(
    path: Path,
    read: ReadColumns,
    message_class: Callable[[str], type[Message]],
    columns: Columns,
    *,
    on: str | float,
    method: str = 'nearest',
    tolerance: float | None = None,
    stamp: str = 'header',
) -> dict[str, Array]:
    """The columns of ``Bag.align``: ``time`` (the reference instants, int64 ns), then
    ``topic.field`` (float64, NaN where nothing matched)."""
    limit = _check(method, stamp, tolerance)
    wanted = requested(columns)
    if not wanted:
        raise ValueError('align() needs at least one topic in columns')
    aligner = Aligner(path, read, message_class, stamp)
    period = None if isinstance(on, str) else _period_ns(on)
    topics: dict[str, tuple[list[Leaf], _Topic]] = {}
    for name, fields in wanted.items():
        topics[name] = aligner.topic(name, fields)
    if isinstance(on, str) and on not in topics:
        topics[on] = aligner.topic(on, [])
    if aligner.headerless:
        warnings.warn(
            f'align: no header stamp in {", ".join(aligner.headerless)}: receive times are '
            "used there (stamp='receive' uses them for every topic)",
            stacklevel=3,
        )
    if isinstance(on, str):
        instants = topics[on][1].every_stamp
    else:
        assert period is not None
        firsts = [t.stamps[0] for _, t in topics.values() if len(t.stamps)]
        lasts = [t.stamps[-1] for _, t in topics.values() if len(t.stamps)]
        if firsts:
            rows = (max(lasts) - min(firsts)) // period + 1
            if rows > MAX_GRID_ROWS:
                raise ValueError(
                    f'a period of {on} s over {(max(lasts) - min(firsts)) / _NS:.3f} s of data is '
                    f'{rows:,} rows (at most {MAX_GRID_ROWS:,}): use a longer period, or '
                    "on='/topic' for a row per message of that topic"
                )
            instants = np.arange(min(firsts), max(lasts) + 1, period, dtype=np.int64)
        else:
            instants = np.empty(0, np.int64)
    result: dict[str, Array] = {TIME: np.asarray(instants, np.int64)}
    flat: list[str] = []
    for name, (leaves, topic) in topics.items():
        if name not in wanted:
            continue
        if name == on:  # the reference topic: its own messages, row for row
            for leaf in leaves:
                column = topic.columns[leaf.path][topic.every]
                result[f'{name}.{leaf.path}'] = column.astype(np.float64)
            continue
        low, high, weight, ok = _match(topic, instants, method, limit)
        nearest = np.where(weight > 0.5, high, low) if method == 'linear' else low
        if len(topic.rows):  # positions among the distinct stamps -> rows of the columns
            low, high, nearest = topic.rows[low], topic.rows[high], topic.rows[nearest]
        for leaf in leaves:
            column = topic.columns[leaf.path]
            if method == 'linear' and leaf.value == np.bool_:
                flat.append(f'{name}.{leaf.path}')
                result[f'{name}.{leaf.path}'] = _fill(
                    column, nearest, high, weight, ok, interpolate=False
                )
            else:
                interpolate = method == 'linear'
                result[f'{name}.{leaf.path}'] = _fill(
                    column, low, high, weight, ok, interpolate=interpolate
                )
    if flat:
        warnings.warn(
            f'align: linear cannot interpolate {", ".join(flat)} (not numbers); '
            'they take the nearest value',
            stacklevel=3,
        )
    return result


__all__ = ['METHODS', 'STAMPS', 'Columns', 'align', 'requested']
