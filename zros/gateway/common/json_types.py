"""The JSON objects the gateways exchange with web clients (rosbridge, rosapi, Foxglove)."""

from __future__ import annotations

from collections.abc import Mapping

from zros.cdr import JsonValue
from zros.gateway.common.errors import GatewayError

#: one JSON object: a rosbridge operation, a rosapi request or reply
JsonObject = dict[str, JsonValue]
#: a message to a client: JSON values, and for CBOR also bytes and typed arrays (CBOR tags)
OutObject = Mapping[str, object]


def text_field(op: JsonObject, name: str, default: str | None = None) -> str:
    """The string ``op[name]``, ``default`` when missing (GatewayError when missing without a
    default, or not a string)."""
    value = op.get(name, default)
    if not isinstance(value, str):
        raise GatewayError(f'the field {name} must be a string, not {value!r}')
    return value


def optional_text(op: JsonObject, name: str) -> str | None:
    """The string ``op[name]``, None when missing or null (GatewayError when not a string)."""
    return None if op.get(name) is None else text_field(op, name)


def int_field(op: JsonObject, name: str, default: int = 0) -> int:
    """The integer ``op[name]``, ``default`` when missing, null or 0 (GatewayError when not an
    integer)."""
    value = op.get(name) or default
    if not isinstance(value, int) or isinstance(value, bool):
        raise GatewayError(f'the field {name} must be an integer, not {value!r}')
    return value
