"""What the runtime does per wire scheme, behind one interface (:class:`Wire`).

A node opens the wire it speaks (``wire=`` or ``ZROS_WIRE``) with :func:`open_wire`; its
entities ask it for their place (:meth:`Wire.entity`: key, tokens, GID) and then ask that
place (:class:`WireEntity`) what to attach, which samples to accept, how to answer queries.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from zros.wire.base import KeyScheme, Wire, WireEntity
from zros.wire.bridge_wire import (
    BridgeInfo,
    BridgeWire,
    ask_bridge,
    bridges_at_start,
    query_bridges,
)
from zros.wire.requests import Requests
from zros.wire.rmw_zenoh_wire import RmwZenohWire, SequenceNumbers, read_attachment

if TYPE_CHECKING:
    from zros.cdr import TypeRegistry
    from zros.transport import Transport

#: the schemes zros speaks, by name
WIRES: dict[str, type[Wire]] = {'bridge': BridgeWire, 'rmw_zenoh': RmwZenohWire}


def check_wire(wire: str) -> str:
    """``wire`` if it names a scheme zros speaks, else ValueError."""
    if wire not in WIRES:
        raise ValueError(f'wire must be "bridge" or "rmw_zenoh", got {wire!r}')
    return wire


def open_wire(
    wire: str,
    transport: Transport,
    namespace: str,
    node_name: str,
    registry: TypeRegistry,
    *,
    bridge_namespace: str | None = None,
    domain_id: int | None = None,
) -> Wire:
    """The wire ``wire`` for the node ``namespace``/``node_name`` on ``transport``; TypeError
    for an option the scheme does not take."""
    return WIRES[check_wire(wire)](
        transport, namespace, node_name, registry,
        bridge_namespace=bridge_namespace, domain_id=domain_id,
    )  # fmt: skip


def any_type_key(wire: str, key: str) -> str:
    """The key expression matching every type on ``key`` as the graph shows it for ``wire``."""
    return WIRES[check_wire(wire)].any_type_key(key)


__all__ = [
    'WIRES',
    'BridgeInfo',
    'BridgeWire',
    'KeyScheme',
    'Requests',
    'RmwZenohWire',
    'SequenceNumbers',
    'Wire',
    'WireEntity',
    'any_type_key',
    'ask_bridge',
    'bridges_at_start',
    'check_wire',
    'open_wire',
    'query_bridges',
    'read_attachment',
]
