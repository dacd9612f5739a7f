"""The JSON values the gateways exchange with web clients (rosbridge, rosapi, Foxglove)."""

from __future__ import annotations

from typing import Any

#: a JSON value from or to a client: a boundary, its shape is checked where it is read
JsonValue = Any
#: one JSON object: a rosbridge operation, a rosapi request or reply
JsonObject = dict[str, JsonValue]
