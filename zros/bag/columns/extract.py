"""Numeric fields of a topic as numpy columns, read straight from the CDR bytes.

A topic is read in batches of chunks. Each batch goes through the plan of its type
(:mod:`zros.bag.columns.rows`: a handful of numpy calls per field, since recorded sensor data has
few layouts) and fills the topic's columns (:mod:`zros.bag.columns.column`), allocated once for
its message count. Messages the plan cannot read (big-endian, sequences of strings before the
fields, too many distinct layouts, data that does not fit the type) are decoded one by one
instead, which also gives the reader's definition fallback and errors.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sized
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from zros.bag.columns.column import Column
from zros.bag.columns.plan import Leaf, Plan, plan, select
from zros.bag.columns.rows import Pieces, Unplannable, payloads_of, read_rows
from zros.cdr.arrays import Array, DType

if TYPE_CHECKING:
    from typing import TypeAlias

    import pandas as pd  # type: ignore[import-untyped,unused-ignore]  # optional, not installed

    DataFrame: TypeAlias = pd.DataFrame  #: pandas' DataFrame (typed where pandas-stubs is)

from zros.bag.errors import BagError, Unsupported
from zros.bag.read.payloads import Payloads
from zros.bag.read.source import Block, Connection, RawMessage, Source
from zros.bag.read.types import BagTypes
from zros.cdr.message import Message

TIME = 'time'
#: messages read per batch (bounds the chunk buffers held at once)
BATCH = 65536
#: chunk bytes held per batch (the same bound for large messages, or chunks of many topics)
BATCH_BYTES = 64 << 20


def _slow(types: BagTypes, block: Block, leaves: list[Leaf]) -> tuple[Pieces, Array]:
    """Decode one by one (with the reader's definition fallback) and pick the fields; also the
    positions of the messages kept (those no definition decodes are reported and skipped)."""
    getters = [(leaf, leaf.path.split('.')) for leaf in leaves]
    values: dict[str, list[object]] = {leaf.path: [] for leaf in leaves}
    connection = block.connection
    kept = []
    for row, (stamp, data) in enumerate(zip(block.times.tolist(), block.data, strict=True)):
        message = types.decode_or_skip(RawMessage(connection, stamp, data))
        if message is None:
            continue
        kept.append(row)
        for leaf, parts in getters:
            value: object = message
            for part in parts:
                value = getattr(value, part if hasattr(value, part) else part + '_')
            values[leaf.path].append(value)
    where = np.arange(len(kept), dtype=np.int64)
    pieces: Pieces = {}
    for leaf in leaves:
        column = values[leaf.path]
        if leaf.sequence:
            groups: dict[int, list[int]] = {}
            for row, value in enumerate(column):
                assert isinstance(value, Sized)  # a sequence field's value
                groups.setdefault(len(value), []).append(row)
            pieces[leaf.path] = [
                (where[rows], _stack([column[r] for r in rows], leaf, size))
                for size, rows in groups.items()
            ]
        else:
            pieces[leaf.path] = [(where, _stack(column, leaf, leaf.length))]
    return pieces, np.asarray(kept, np.int64)


def _stack(values: list[object], leaf: Leaf, width: int) -> Array:
    if not values:
        return np.empty((0, width) if width or leaf.sequence else 0, leaf.value)
    return np.asarray(values, dtype=leaf.value)


def _leaves(path: Path, topic: str, cls: type[Message], fields: list[str] | None) -> list[Leaf]:
    try:
        return select(plan(cls), fields, cls.__msgtype__)
    except ValueError as exc:
        raise BagError(path, f'topic {topic}: {exc}') from None


def _take(messages: Iterator[RawMessage], count: int, size: int) -> list[RawMessage]:
    """The next ``count`` messages, or fewer holding ``size`` bytes."""
    batch = []
    held = 0
    for raw in messages:
        batch.append(raw)
        held += len(raw.data)
        if len(batch) == count or held >= size:
            break
    return batch


def _message_blocks(
    source: Source, connections: list[Connection], start: int | None, end: int | None
) -> Iterator[list[Block]]:
    """Blocks made from the message stream, for storages that cannot be read in chunks."""
    messages = source.messages(connections, start, end)
    counter = 0
    while batch := _take(messages, BATCH, BATCH_BYTES):
        grouped: dict[int, tuple[Connection, list[int], list[int], list[bytes]]] = {}
        for key, raw in enumerate(batch, counter):
            entry = grouped.get(raw.connection.id)
            if entry is None:
                entry = grouped[raw.connection.id] = (raw.connection, [], [], [])
            entry[1].append(raw.timestamp)
            entry[2].append(key)
            entry[3].append(bytes(raw.data))
        counter += len(batch)
        yield [
            Block(conn, np.asarray(times, np.int64), np.asarray(keys, np.int64), datas)
            for conn, times, keys, datas in grouped.values()
        ]


class _Extraction:
    """Columns of one topic built block by block, then put in time order."""

    def __init__(
        self, types: BagTypes, topic: str, fields: list[str] | None, capacity: int
    ) -> None:
        self.types = types
        self.path = types.path
        self.topic = topic
        self.fields = fields
        self.capacity = capacity
        self.plans: dict[int, tuple[Plan, list[Leaf]]] = {}
        self.leaves: list[Leaf] | None = None
        self.times: list[Array] = []
        self.keys: list[Array] = []
        self.columns: dict[str, Column] = {}
        self.pending: dict[int, list[Block]] = {}
        self.queued: dict[int, tuple[int, int]] = {}  #: messages and bytes pending

    def add(self, blocks: list[Block]) -> None:
        for block in blocks:
            cid = block.connection.id
            queue = self.pending.setdefault(cid, [])
            queue.append(block)
            count, size = self.queued.get(cid, (0, 0))
            self.queued[cid] = count, size = count + len(block.times), size + _size(block)
            if count >= BATCH or size >= BATCH_BYTES:
                self._flush(cid)

    def finish(self, connections: list[Connection]) -> dict[str, Array]:
        for cid in list(self.pending):
            self._flush(cid)
        if self.leaves is None:
            # no message to settle the definition with: the class the reader would start with
            cls = self.types.message_class(connections[0])
            self.leaves = _leaves(self.path, self.topic, cls, self.fields)
        times = np.concatenate(self.times) if self.times else np.empty(0, np.int64)
        keys = np.concatenate(self.keys) if self.keys else np.empty(0, np.int64)
        order = None
        if len(times) > 1:
            later = np.diff(times)
            if (later < 0).any() or ((later == 0) & (np.diff(keys) < 0)).any():
                order = np.lexsort((keys, times))
        result = {TIME: times if order is None else times[order]}
        for leaf in self.leaves:
            column = self.columns.get(leaf.path) or Column(leaf, 0)
            result[leaf.path] = column.result(order)
        return result

    def _settle(self, queue: list[Block]) -> tuple[Plan, list[Leaf]] | None:
        """The plan of a connection, once a message settles which definition fits the data
        (None while every message so far is damaged)."""
        block = queue[0]
        messages = (
            RawMessage(b.connection, stamp, data)
            for b in queue
            for stamp, data in zip(b.times.tolist(), b.data, strict=True)
        )
        if all(self.types.decode_or_skip(raw) is None for raw in messages):
            return None
        cls = self.types.message_class(block.connection)
        own = _leaves(self.path, self.topic, cls, self.fields)
        if self.leaves is None:
            self.leaves = own
        elif [leaf.path for leaf in own] != [leaf.path for leaf in self.leaves]:
            raise BagError(self.path, f'topic {self.topic} holds types with different fields')
        return plan(cls), own

    def _flush(self, cid: int) -> None:
        queue = self.pending.pop(cid, [])
        self.queued.pop(cid, None)
        if not queue:
            return
        batch = [payloads_of(b.data) for b in queue]
        times = np.concatenate([b.times for b in queue])
        keys = np.concatenate([b.keys for b in queue])
        known = self.plans.get(cid)
        if known is None:
            known = self._settle(queue)
            if known is None:
                return  # every message damaged (reported)
            self.plans[cid] = known
        plan_, own = known
        try:
            found = read_rows(plan_, own, batch)
        except Unplannable:
            datas = [data for payloads in batch for data in payloads]
            found, kept = _slow(self.types, Block(queue[0].connection, times, keys, datas), own)
            if len(kept) < len(times):
                times, keys = times[kept], keys[kept]
        for leaf in own:
            column = self.columns.get(leaf.path)
            if column is None:
                column = self.columns[leaf.path] = Column(leaf, self.capacity)
            column.add(found[leaf.path], len(times))
        self.times.append(times)
        self.keys.append(keys)


def _size(block: Block) -> int:
    """Bytes a block holds: its chunk's (decompressed or mapped), where its payloads lie in one,
    since the other channels' messages in it stay alive as long as the block."""
    data = block.data
    return len(data.buffer) if isinstance(data, Payloads) else sum(map(len, data))


def _capacity(
    source: Source, connections: list[Connection], start: int | None, end: int | None
) -> int:
    """How many messages a topic's columns are allocated for: its count, or twice its share
    of the time window (rows never written are never faulted in; columns grow past it, a
    copy, where the window holds more)."""
    count = sum(c.count for c in connections)
    if start is None and end is None:
        return count
    first = max(source.start_ns, start if start is not None else source.start_ns)
    last = min(source.end_ns + 1, end if end is not None else source.end_ns + 1)
    span = source.end_ns + 1 - source.start_ns
    if last <= first or span <= 0:
        return 0
    return min(count, 2 * int(count * (last - first) / span) + BATCH)


def extract(
    source: Source,
    types: BagTypes,
    connections: list[Connection],
    fields: Iterable[str] | None,
    *,
    start: int | None,
    end: int | None,
) -> dict[str, Array]:
    """The columns of ``Bag.columns``: the messages of ``connections`` (one topic's) in
    ``source``, decoded with ``types`` where the plan cannot read them."""
    requested = None if fields is None else ([fields] if isinstance(fields, str) else list(fields))
    topic = connections[0].topic
    names = {c.type_name for c in connections}
    if len(names) > 1:
        raise BagError(
            source.path, f'topic {topic} holds several types: {", ".join(sorted(names))}'
        )
    types.message_class(connections[0])  # a type with no definition has no columns
    capacity = _capacity(source, connections, start, end)
    extraction = _Extraction(types, topic, requested, capacity)
    try:
        for blocks in source.blocks(connections, start, end):
            extraction.add(blocks)
    except Unsupported:
        extraction = _Extraction(types, topic, requested, capacity)
        for blocks in _message_blocks(source, connections, start, end):
            extraction.add(blocks)
    return extraction.finish(connections)


def structured(columns: dict[str, Array], path: Path) -> Array:
    """Columns as one structured array; ragged columns cannot be part of one."""
    fields: list[tuple[str, DType, tuple[int, ...]]] = []
    for name, column in columns.items():
        if column.dtype == object:
            raise BagError(
                path,
                f'column {name} holds sequences of different lengths; '
                'use columns() for it, or leave it out of fields',
            )
        fields.append((name, column.dtype, column.shape[1:]))
    size = len(columns[TIME])
    out = np.empty(size, np.dtype(fields))
    for name, column in columns.items():
        out[name] = column
    return out


def dataframe(columns: dict[str, Array]) -> DataFrame:
    """Columns as a pandas DataFrame; 2-D columns spread over ``name[i]`` columns, views of
    the arrays (a copy, as pandas makes by default, would double the peak memory)."""
    try:
        import pandas as pd  # type: ignore[import-untyped,unused-ignore]  # noqa: PLC0415 (optional: pandas, for to_pandas only)
    except ImportError:
        raise ImportError(
            'to_dataframe() needs pandas, which zros does not install: pip install pandas '
            '(columns() and to_numpy() give the same data as numpy arrays)'
        ) from None
    data: dict[str, Array | list[object]] = {}
    for name, column in columns.items():
        if column.ndim == 2:
            for index in range(column.shape[1]):
                data[f'{name}[{index}]'] = column[:, index]
        else:
            data[name] = list(column) if column.dtype == object else column
    return pd.DataFrame(data, copy=False)


__all__ = ['TIME', 'dataframe', 'extract', 'structured']
