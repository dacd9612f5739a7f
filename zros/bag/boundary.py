"""Names for the values of bag files' YAML documents."""

from __future__ import annotations

from zros.cdr.model import JsonValue

#: a value of a YAML document (``metadata.yaml``, QoS profiles): JSON's shapes, checked
#: (isinstance) where it is read
YamlValue = JsonValue
