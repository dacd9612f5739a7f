"""The JSON objects the gateways exchange with web clients (rosbridge, rosapi, Foxglove)."""

from __future__ import annotations

from zros.cdr import JsonValue

#: one JSON object: a rosbridge operation, a rosapi request or reply
JsonObject = dict[str, JsonValue]
