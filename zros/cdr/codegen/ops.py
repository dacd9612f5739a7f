"""The operations a message flattens into, and what the generators track about offsets.

Both codecs walk a message into a list of operations in wire order; the decoder and the encoder
then emit code for them, merging runs of fixed-size operations into one ``struct`` call where
the :class:`State` says their alignment is known statically.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from zros.cdr.arrays import DType
from zros.cdr.layout import StructInfo, numpy_dtype
from zros.cdr.model import FieldType, MessageDef
from zros.cdr.naming import attribute_name

#: the ``struct`` code of each primitive
STRUCT_CODES = {
    'bool': '?',
    'byte': 'B',
    'char': 'B',
    'int8': 'b',
    'uint8': 'B',
    'int16': 'h',
    'uint16': 'H',
    'int32': 'i',
    'uint32': 'I',
    'int64': 'q',
    'uint64': 'Q',
    'float32': 'f',
    'float64': 'd',
}


class Context(Protocol):
    """What the generator needs to know about other types."""

    def resolve(self, name: str) -> MessageDef:
        """The definition of a message type."""
        ...

    def info(self, name: str) -> StructInfo:
        """The layout facts of a message type."""
        ...

    def cls(self, name: str) -> type:
        """The class of a message type."""
        ...

    def dtype(self, name: str, endian: str) -> DType:
        """The structured dtype of a uniform message type."""
        ...


def value_dtype(primitive: str) -> DType:
    """The dtype of a primitive array field's value (numpy bool for ``bool``)."""
    return np.dtype('?') if primitive == 'bool' else numpy_dtype(primitive, '<')


# --- operations ---------------------------------------------------------------------------


@dataclass
class Fix:
    """A fixed-size scalar: decode stores into ``ref``; encode writes the expression ``ref``."""

    code: str
    size: int
    ref: str | None
    path: str
    primitive: str = ''


@dataclass
class FixArr:
    """A fixed-size array of a primitive (a numpy array)."""

    primitive: str
    count: int
    ref: str
    path: str


@dataclass
class Pre:
    """Statements with no wire effect, emitted at once (object creation, hoisting, checks)."""

    lines: list[str]


@dataclass
class Str:
    """A string or wstring body after its count (decoding)."""

    ref: str
    count: str
    bound: int
    path: str
    wide: bool


@dataclass
class Seq:
    """A primitive sequence (``element`` is a primitive) or a uniform struct sequence."""

    element: str
    ref: str
    count: str
    bound: int
    path: str
    struct: bool


@dataclass
class Blob:
    """Variable-size bytes: a string body plus its NUL, a wstring body, or a sequence array
    (encoding)."""

    ref: str
    size: str
    align: int  #: alignment of the data, applied only when the count is not 0
    count: str  #: the element count; the data is written only when it is not 0
    nul: bool  #: a string: write a NUL after the data
    conditional: bool  #: a sequence (aligned and written only when count > 0)


@dataclass
class Loop:
    """A loop over the elements of a sequence or array of non-uniform structs or strings."""

    count: str
    bound: int
    min_size: int
    ref: str
    item: str
    index: str
    body: list[Op]
    path: str


Op = Fix | FixArr | Pre | Str | Seq | Blob | Loop


def fields_of(msg: MessageDef, var: str, path: str) -> list[tuple[str, str, FieldType]]:
    """Each field of ``msg`` (held in the generated variable ``var``, at ``path`` in the
    message): its attribute expression, its dotted path and its type."""
    return [
        (f'{var}.{attribute_name(f.name)}', f'{path}.{f.name}' if path else f.name, f.type)
        for f in msg.fields
    ]


def empty_message(path: str) -> Fix:
    """The one placeholder byte of a message without fields."""
    return Fix('x', 1, None, path or '(empty message)')


# --- static offsets -------------------------------------------------------------------------


@dataclass(frozen=True)
class State:
    """The body offset is known to be ``mod`` modulo ``modulus``."""

    mod: int
    modulus: int

    def advance(self, size: int) -> State:
        """The state ``size`` bytes further."""
        return State((self.mod + size) % self.modulus, self.modulus)

    def static_pad(self, align: int) -> int | None:
        """The padding before data aligned to ``align``, or None when it is known only at run
        time."""
        if align == 1:
            return 0
        if self.modulus >= align:
            return -self.mod % align
        return None


#: nothing is known about the offset
UNKNOWN = State(0, 1)
#: the start of the body (the 4-byte header keeps it aligned to 8)
START = State(0, 8)


def loop_entry(before: State, element: Callable[[State], State]) -> State:
    """What is known at the start of every element of a loop entered in state ``before``, where
    ``element(state)`` is the state after one element that started in ``state``: the first
    alignment of a TransformStamped is static when the one before it ended aligned.

    The answer holds before the loop and after any element started in it, so it also holds
    after the loop.
    """
    entry = before
    for _ in range(4):  # each entry is merge_state(before, ...): it differs only in modulus
        after = merge_state(before, element(entry))
        if after == entry:
            return entry
        entry = after
    return UNKNOWN


class LoopStates:
    """The entry state of each loop (:func:`loop_entry`), found once per loop and state before
    it: ``after_element(loop, state)`` dry-runs one element. Found anew each time, the dry runs
    of loops nested in loops would multiply with the depth (3^depth emissions of the body)."""

    def __init__(self, after_element: Callable[[Loop, State], State]) -> None:
        self._after_element = after_element
        self._known: dict[tuple[int, State], State] = {}

    def entry(self, loop: Loop, before: State) -> State:
        """What is known at the start of every element of ``loop``, entered in ``before``."""
        key = (id(loop), before)
        known = self._known.get(key)
        if known is None:
            known = loop_entry(before, lambda start: self._after_element(loop, start))
            self._known[key] = known
        return known


def merge_state(a: State, b: State) -> State:
    """What is known after either of two paths (an ``if`` that wrote data or did not)."""
    modulus = min(a.modulus, b.modulus)
    while modulus > 1 and a.mod % modulus != b.mod % modulus:
        modulus //= 2
    return State(a.mod % modulus, modulus)
