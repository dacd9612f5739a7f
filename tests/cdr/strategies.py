"""Hypothesis strategies for random messages of any zros type."""

from __future__ import annotations

from typing import Any

import numpy as np
from hypothesis import strategies as st

from zros.cdr.layout import VALUE_CODES
from zros.cdr.model import INTEGER_RANGES, FieldType, Kind
from zros.cdr.naming import attribute_name
from zros.cdr.registry import TypeRegistry

MAX_SEQUENCE = 3

_TEXT = st.characters(exclude_categories=('Cs',), exclude_characters='\x00')
_BMP_TEXT = st.characters(
    exclude_categories=('Cs',), exclude_characters='\x00', max_codepoint=0xFFFF
)


def scalar_strategy(primitive: str, signed_byte_range: bool = False) -> st.SearchStrategy[Any]:
    if primitive == 'bool':
        return st.booleans()
    if primitive == 'byte' and signed_byte_range:
        return st.integers(0, 127)
    if primitive in INTEGER_RANGES:
        low, high = INTEGER_RANGES[primitive]
        return st.integers(low, high)
    width = 32 if primitive == 'float32' else 64
    return st.floats(width=width, allow_nan=False)


def string_strategy(ftype: FieldType) -> st.SearchStrategy[str]:
    if ftype.base == 'wstring':
        if ftype.string_bound:
            return st.text(_BMP_TEXT, max_size=ftype.string_bound)
        return st.text(_TEXT, max_size=8)
    if ftype.string_bound:
        return st.text(_TEXT, max_size=ftype.string_bound).filter(
            lambda s: len(s.encode()) <= ftype.string_bound
        )
    return st.text(_TEXT, max_size=12)


def _sizes(ftype: FieldType) -> st.SearchStrategy[int]:
    if ftype.kind is Kind.ARRAY:
        return st.just(ftype.length)
    if ftype.kind is Kind.BOUNDED:
        return st.integers(0, min(ftype.length, MAX_SEQUENCE))
    return st.integers(0, MAX_SEQUENCE)


def field_strategy(
    registry: TypeRegistry, ftype: FieldType, signed_byte_range: bool = False
) -> st.SearchStrategy[Any]:
    if ftype.kind is Kind.SCALAR:
        if ftype.is_primitive:
            return scalar_strategy(ftype.base, signed_byte_range)
        if ftype.is_string:
            return string_strategy(ftype)
        return message_strategy(registry, ftype.base, signed_byte_range)
    element: st.SearchStrategy[Any]
    if ftype.is_primitive:
        element = scalar_strategy(ftype.base, signed_byte_range)
        dtype = np.dtype(VALUE_CODES[ftype.base])
        return _sizes(ftype).flatmap(
            lambda n: st.lists(element, min_size=n, max_size=n).map(
                lambda values: np.array(values, dtype=dtype)
            )
        )
    element = (
        string_strategy(ftype.element)
        if ftype.is_string
        else message_strategy(registry, ftype.base, signed_byte_range)
    )
    return _sizes(ftype).flatmap(lambda n: st.lists(element, min_size=n, max_size=n))


_cache: dict[tuple[int, str, bool], st.SearchStrategy[Any]] = {}


def message_strategy(
    registry: TypeRegistry, name: str, signed_byte_range: bool = False
) -> st.SearchStrategy[Any]:
    """Random instances of the message ``name`` (sequences hold 0 to 3 elements).

    ``signed_byte_range`` keeps ``byte`` values in 0..127, where rosbags (which reads ``byte``
    as the ROS 1 int8) and ROS 2 (an octet, 0..255) agree.
    """
    key = (id(registry), name, signed_byte_range)
    if key not in _cache:
        cls = registry.get_class(name)
        definition = registry.message_definition(name)
        fields = {
            attribute_name(f.name): st.deferred(
                lambda f=f: field_strategy(registry, f.type, signed_byte_range)
            )
            for f in definition.fields
        }
        _cache[key] = st.builds(cls, **fields)
    return _cache[key]
