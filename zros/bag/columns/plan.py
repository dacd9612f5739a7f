"""Field paths of a message type and the plan that reads them straight from CDR bytes.

A plan is the message's wire layout as a list of steps: a *block* of fixed-size fields whose
offsets inside the block are static (the block starts at its largest alignment), a *string*, a
*sequence* of primitives, or a sequence of fixed-size structs. Between steps the position
depends on the data; inside a block it does not. :mod:`zros.bag.columns.extract` runs a plan on many
messages at once with numpy.
"""

from __future__ import annotations

import keyword
import weakref
from dataclasses import dataclass, field

import numpy as np

from zros.cdr.arrays import DType
from zros.cdr.layout import VALUE_CODES, numpy_dtype
from zros.cdr.message import Message, definition_of
from zros.cdr.model import PRIMITIVE_SIZES, Kind, MessageDef
from zros.cdr.registry import registry_of


@dataclass(frozen=True)
class Leaf:
    """A numeric field: its path, value dtype and, for fixed arrays, its length (else 0)."""

    path: str
    wire: DType  #: the dtype on the wire (bool is a byte)
    value: DType  #: the dtype of the column
    length: int = 0
    sequence: bool = False


@dataclass
class Step:
    """One step of a plan (see the module docstring)."""

    kind: str  #: 'block', 'string', 'sequence', 'structs' or 'stop'
    align: int = 1
    size: int = 0  #: block size, element size, or character size of a string
    #: block: (offset in the block, leaf); sequence: (0, leaf) or nothing when not numeric
    leaves: list[tuple[int, Leaf]] = field(default_factory=list)
    where: str = ''  #: the field a 'stop' step could not plan

    def add(self, align: int, size: int, leaf: Leaf | None) -> None:
        """Append a fixed field to a block."""
        self.size += -self.size % align
        if leaf is not None:
            self.leaves.append((self.size, leaf))
        self.size += size


@dataclass
class Plan:
    """The steps of one message type, and every field path it has."""

    steps: list[Step]
    leaves: list[Leaf]  #: numeric fields, in wire order
    other: list[str]  #: paths of fields that are not numeric (strings, structs in lists)
    complete: bool  #: False when a field could not be planned (see the 'stop' step)


class _Planner:
    def __init__(self, cls: type[Message]) -> None:
        self.registry = registry_of(cls)
        self.layout = self.registry.layout
        self.steps: list[Step] = []
        self.leaves: list[Leaf] = []
        self.other: list[str] = []
        self.stopped = False

    def _block(self, align: int) -> Step:
        last = self.steps[-1] if self.steps else None
        if last is not None and last.kind == 'block' and last.align >= align:
            return last
        step = Step('block', align)
        self.steps.append(step)
        return step

    def fixed(self, primitive: str, count: int, path: str | None) -> None:
        size = PRIMITIVE_SIZES[primitive]
        leaf = None
        if path is not None:
            wire = numpy_dtype(primitive)
            leaf = Leaf(path, wire, np.dtype(VALUE_CODES[primitive]).newbyteorder('='), count)
            self.leaves.append(leaf)
        if not self.stopped:
            self._block(size).add(size, size * max(count, 1), leaf)

    def message(self, msg: MessageDef, prefix: str, named: bool = True) -> None:
        if not msg.fields:
            self.fixed('uint8', 0, None)  # the placeholder byte of an empty message
            return
        for f in msg.fields:
            path = prefix + f.name if named else None
            t = f.type
            if t.is_primitive:
                if t.kind is Kind.SCALAR:
                    self.fixed(t.base, 0, path)
                elif t.kind is Kind.ARRAY:
                    self.fixed(t.base, t.length, path)
                else:
                    leaf = None
                    if path is not None:
                        wire = numpy_dtype(t.base)
                        value = np.dtype(VALUE_CODES[t.base]).newbyteorder('=')
                        leaf = Leaf(path, wire, value, 0, True)
                        self.leaves.append(leaf)
                    size = PRIMITIVE_SIZES[t.base]
                    self.append(Step('sequence', 4, size, [(0, leaf)] if leaf else []))
            elif t.is_string:
                if path is not None:
                    self.other.append(path)
                char = 4 if t.base == 'wstring' else 1
                count = t.length if t.kind is Kind.ARRAY else 1
                if t.kind in (Kind.BOUNDED, Kind.SEQUENCE):
                    self.stop(prefix + f.name)
                for _ in range(count):
                    self.append(Step('string', 4, char))
            else:
                sub = self.registry.message_definition(t.base)
                if t.kind is Kind.SCALAR:
                    self.message(sub, f'{path}.' if path is not None else '', named)
                elif t.kind is Kind.ARRAY:
                    if path is not None:
                        self.other.append(path)
                    for _ in range(t.length):
                        self.message(sub, '', False)
                else:
                    if path is not None:
                        self.other.append(path)
                    info = self.layout.info(t.base)
                    if not info.uniform:
                        self.stop(prefix + f.name)
                    self.append(Step('structs', info.first_align, info.size))

    def append(self, step: Step) -> None:
        if not self.stopped:
            self.steps.append(step)

    def stop(self, where: str) -> None:
        """No step after this field can be planned; its leaves are still listed."""
        self.append(Step('stop', where=where))
        self.stopped = True


_plans: weakref.WeakKeyDictionary[type[Message], Plan] = weakref.WeakKeyDictionary()


def plan(cls: type[Message]) -> Plan:
    """The plan of a message class (cached while the class lives)."""
    known = _plans.get(cls)
    if known is None:
        planner = _Planner(cls)
        planner.message(definition_of(cls), '')
        known = Plan(planner.steps, planner.leaves, planner.other, not planner.stopped)
        _plans[cls] = known
    return known


def ros_path(path: str) -> str:
    """A field path with Python attribute spellings (``from_``) turned into ROS names."""
    parts = path.strip().split('.')
    return '.'.join(p[:-1] if p.endswith('_') and keyword.iskeyword(p[:-1]) else p for p in parts)


def select(plan: Plan, fields: list[str] | None, type_name: str) -> list[Leaf]:
    """The leaves ``fields`` name (a path of a struct selects its numeric fields).

    Raises ValueError naming the path that is unknown or not numeric.
    """
    if fields is None:
        return list(plan.leaves)
    chosen: dict[str, Leaf] = {}
    for requested in fields:
        path = ros_path(requested)
        found = [leaf for leaf in plan.leaves if leaf.path == path]
        found = found or [leaf for leaf in plan.leaves if leaf.path.startswith(path + '.')]
        if not found:
            if path in plan.other or any(o.startswith(path + '.') for o in plan.other):
                raise ValueError(
                    f'{type_name} field {requested!r} is not numeric (strings and lists of '
                    'messages have no columns)'
                )
            raise ValueError(
                f'{type_name} has no field {requested!r}; its numeric fields are: '
                + ', '.join(leaf.path for leaf in plan.leaves)
            )
        for leaf in found:
            chosen.setdefault(leaf.path, leaf)
    return list(chosen.values())
