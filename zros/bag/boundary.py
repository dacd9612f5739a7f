"""Names for the values of the command-line tools, bags and gateways that have no static type."""

from __future__ import annotations

from typing import Any

#: a message field's value: its type is the message definition's, known only at run time
FieldValue = Any
#: an object of a library without type information for it (ruamel.yaml, pandas): its own
#: checks apply
Untyped = Any
#: a connection setting passed on to :class:`zros.Node` (``connect``, ``wire``...), checked there
NodeSetting = Any
#: a parameter's value as it crosses to users: its type is the parameter's, known at run time
ParamValue = Any
#: a value of a YAML document (``metadata.yaml``, QoS profiles): checked where it is read
YamlValue = Any
