"""Convert zros messages to rosbags messages, for comparing the two serializers."""

from __future__ import annotations

from typing import Any

import numpy as np

from zros.cdr.layout import VALUE_CODES
from zros.cdr.model import Kind
from zros.cdr.naming import attribute_name
from zros.cdr.registry import TypeRegistry
from zros.cdr.typestore import PLACEHOLDER_FIELD


def to_rosbags(registry: TypeRegistry, typestore: Any, message: Any) -> Any:
    """The rosbags dataclass instance with the same content as a zros message."""
    name = message.__msgtype__
    definition = registry.message_definition(name)
    cls = typestore.types[name]
    if not definition.fields:
        return cls(**{PLACEHOLDER_FIELD: 0})
    values = {}
    for f in definition.fields:
        value = getattr(message, attribute_name(f.name))
        t = f.type
        if t.is_nested:
            if t.kind is Kind.SCALAR:
                value = to_rosbags(registry, typestore, value)
            else:
                value = [to_rosbags(registry, typestore, item) for item in value]
        elif t.is_primitive and t.kind is not Kind.SCALAR:
            value = np.asarray(value, dtype=VALUE_CODES[t.base])
        elif t.is_string and t.kind is not Kind.SCALAR:
            value = list(value)
        values[attribute_name(f.name)] = value
    return cls(**values)
