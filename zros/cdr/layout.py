"""Static CDR layout facts about message types, used by the code generator.

A struct is *fixed* when its wire size does not depend on its values (no strings, no sequences).
A fixed struct is *uniform* when a sequence of it has the same byte layout for every element
whatever the offset it starts at: its first primitive has the largest alignment and its size is a
multiple of that alignment. A sequence of a uniform struct is one numpy structured array.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import numpy as np

from zros.cdr.arrays import DType
from zros.cdr.model import PRIMITIVE_SIZES, FieldType, Kind, MessageDef
from zros.cdr.naming import attribute_name

Resolver = Callable[[str], MessageDef]

#: numpy type codes without byte order
NUMPY_CODES = {
    'bool': 'u1',
    'byte': 'u1',
    'char': 'u1',
    'int8': 'i1',
    'uint8': 'u1',
    'int16': 'i2',
    'uint16': 'u2',
    'int32': 'i4',
    'uint32': 'u4',
    'int64': 'i8',
    'uint64': 'u8',
    'float32': 'f4',
    'float64': 'f8',
}

#: the numpy dtype a decoded primitive array has (bool arrays become numpy bool)
VALUE_CODES = {**NUMPY_CODES, 'bool': '?'}


@cache
def numpy_dtype(primitive: str, endian: str = '<') -> DType:
    """The wire dtype of a primitive (bool is read as uint8)."""
    code = NUMPY_CODES[primitive]
    return np.dtype(code if code.endswith('1') else endian + code)


@dataclass(frozen=True)
class StructInfo:
    """Layout facts about one message type."""

    fixed: bool
    first_align: int  #: alignment of the first primitive on the wire (1 for an empty struct)
    max_align: int
    size: int  #: wire size from an offset aligned to 8 (fixed structs only, else 0)
    min_size: int  #: a lower bound of the wire size, at least 1
    has_wstring: bool
    uniform: bool  #: fixed, and laid out alike at every element of a sequence


def _field_first_align(
    ftype: FieldType, resolve: Resolver, info: Callable[[str], StructInfo]
) -> int:
    if ftype.kind in (Kind.BOUNDED, Kind.SEQUENCE) or ftype.is_string:
        return 4
    if ftype.is_primitive:
        return PRIMITIVE_SIZES[ftype.base]
    return info(ftype.base).first_align


class LayoutCache:
    """Computes and remembers :class:`StructInfo` per type name."""

    def __init__(self, resolve: Resolver) -> None:
        self._resolve = resolve
        self._infos: dict[str, StructInfo] = {}

    def info(self, name: str) -> StructInfo:
        known = self._infos.get(name)
        if known is None:
            known = self._compute(self._resolve(name))
            self._infos[name] = known
        return known

    def _compute(self, msg: MessageDef) -> StructInfo:
        if not msg.fields:
            return StructInfo(True, 1, 1, 1, 1, False, True)
        fixed = True
        nested_uniform = True
        max_align = 1
        min_size = 0
        has_wstring = False
        for f in msg.fields:
            t = f.type
            count = t.length if t.kind is Kind.ARRAY else 1
            if t.is_string:
                has_wstring = has_wstring or t.base == 'wstring'
            if t.kind in (Kind.BOUNDED, Kind.SEQUENCE) or t.is_string:
                fixed = False
                max_align = max(max_align, 4)
                if t.kind in (Kind.BOUNDED, Kind.SEQUENCE):
                    min_size += 4
                    if t.is_nested:
                        has_wstring = has_wstring or self.info(t.base).has_wstring
                    elif t.is_primitive:
                        max_align = max(max_align, PRIMITIVE_SIZES[t.base])
                else:
                    min_size += 4 * count
                continue
            if t.is_primitive:
                max_align = max(max_align, PRIMITIVE_SIZES[t.base])
                min_size += PRIMITIVE_SIZES[t.base] * count
            else:
                sub = self.info(t.base)
                fixed = fixed and sub.fixed
                nested_uniform = nested_uniform and sub.uniform
                max_align = max(max_align, sub.max_align)
                min_size += sub.min_size * count
                has_wstring = has_wstring or sub.has_wstring
        first = _field_first_align(msg.fields[0].type, self._resolve, self.info)
        size = self._fixed_size(msg, 0) if fixed else 0
        uniform = fixed and nested_uniform and first == max_align and size % max_align == 0
        return StructInfo(fixed, first, max_align, size, max(min_size, 1), has_wstring, uniform)

    def _fixed_size(self, msg: MessageDef, offset: int) -> int:
        return self.walk_fixed(msg, offset) - offset

    def walk_fixed(self, msg: MessageDef, offset: int) -> int:
        """The offset after a fixed struct that starts at ``offset`` (relative to the body)."""
        if not msg.fields:
            return offset + 1
        for f in msg.fields:
            t = f.type
            count = t.length if t.kind is Kind.ARRAY else 1
            if t.is_primitive:
                size = PRIMITIVE_SIZES[t.base]
                if count:
                    offset += -offset % size
                offset += size * count
            else:
                sub = self._resolve(t.base)
                for _ in range(count):
                    offset = self.walk_fixed(sub, offset)
        return offset

    def dtype(self, name: str, endian: str = '<') -> DType:
        """The numpy structured dtype of a uniform struct, laid out as on the wire."""
        msg = self._resolve(name)
        info = self.info(name)
        if not info.uniform:
            raise ValueError(f'{name} has no fixed, uniform layout')
        names: list[str] = []
        formats: list[object] = []
        offsets: list[int] = []
        offset = 0
        if not msg.fields:
            return np.dtype({'names': [], 'formats': [], 'offsets': [], 'itemsize': 1})
        for f in msg.fields:
            t = f.type
            if t.is_primitive:
                size = PRIMITIVE_SIZES[t.base]
                offset += -offset % size
                base: object = numpy_dtype(t.base, endian)
                if t.base == 'bool':
                    base = np.dtype('?')
                step = size
            else:
                sub_info = self.info(t.base)
                offset += -offset % sub_info.first_align
                base = self.dtype(t.base, endian)
                step = sub_info.size
            names.append(attribute_name(f.name))
            offsets.append(offset)
            if t.kind is Kind.ARRAY:
                formats.append((base, (t.length,)))
                offset += step * t.length
            else:
                formats.append(base)
                offset += step
        return np.dtype(
            {'names': names, 'formats': formats, 'offsets': offsets, 'itemsize': info.size}
        )
