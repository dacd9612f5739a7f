"""Names for the values of bag files that have no static type."""

from __future__ import annotations

from typing import Any

#: a value of a YAML document (``metadata.yaml``, QoS profiles): checked where it is read
YamlValue = Any
