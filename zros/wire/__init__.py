"""What the runtime does per wire scheme, behind one interface (:class:`Wire`).

A node opens the wire it speaks (``wire=`` or ``ZROS_WIRE``) with :func:`open_wire`; its
entities ask it for their place (:meth:`Wire.entity`: key, tokens, GID) and then ask that
place (:class:`WireEntity`) what to attach, which samples to accept, how to answer queries.

Only this package and ``zros.keyexpr`` know the schemes (an import-linter contract keeps
``zros.keyexpr.bridge`` and ``zros.keyexpr.rmw_zenoh`` here); the rest asks a :class:`Wire` or
the table :data:`SCHEMES`. The table loads without Zenoh (the command line builds its options
from it); the rest of the package loads on first use.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping

from zros.wire.schemes import (
    DEFAULT_WIRE,
    SCHEMES,
    Scheme,
    WireOption,
    WireSetting,
    check_wire,
    chosen_wire,
    scheme_settings,
)

TYPE_CHECKING = False  # not typing's: `zros --help` imports this package and stays light
if TYPE_CHECKING:
    from collections.abc import Sequence

    from typing_extensions import Unpack

    from zros.cdr import TypeRegistry
    from zros.transport import Transport, TransportConfig
    from zros.transport.config import SessionDefaults, SessionOptions
    from zros.wire.base import KeyScheme, Wire, WireEntity
    from zros.wire.bridge_wire import BridgeWire, ask_bridge, bridges_at_start, query_bridges
    from zros.wire.requests import Requests
    from zros.wire.rmw_zenoh_wire import RmwZenohWire, SequenceNumbers, read_attachment
    from zros.wire.tokens import BridgeInfo, Endpoint, TokenView

#: public name -> module, imported on first access
_LAZY = {
    'KeyScheme': 'zros.wire.base',
    'Wire': 'zros.wire.base',
    'WireEntity': 'zros.wire.base',
    'BridgeInfo': 'zros.wire.tokens',
    'Endpoint': 'zros.wire.tokens',
    'TokenView': 'zros.wire.tokens',
    'BridgeWire': 'zros.wire.bridge_wire',
    'ask_bridge': 'zros.wire.bridge_wire',
    'bridges_at_start': 'zros.wire.bridge_wire',
    'query_bridges': 'zros.wire.bridge_wire',
    'Requests': 'zros.wire.requests',
    'RmwZenohWire': 'zros.wire.rmw_zenoh_wire',
    'SequenceNumbers': 'zros.wire.rmw_zenoh_wire',
    'read_attachment': 'zros.wire.rmw_zenoh_wire',
}


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def wire_class(wire: str) -> type[Wire]:
    """The :class:`Wire` class of the scheme ``wire``."""
    module, _, name = SCHEMES[check_wire(wire)].wire_class.partition(':')
    found: type[Wire] = getattr(importlib.import_module(module), name)
    return found


def open_wire(
    wire: str,
    transport: Transport,
    namespace: str,
    node_name: str,
    registry: TypeRegistry,
    *,
    settings: Mapping[str, WireOption] | None = None,
) -> Wire:
    """The wire ``wire`` for the node ``namespace``/``node_name`` on ``transport``, with the
    scheme's own ``settings`` (None values ignored); TypeError for one it does not take."""
    given = scheme_settings(wire, settings or {})
    return wire_class(wire)(transport, namespace, node_name, registry, given)


def session_defaults(wire: str | None = None) -> SessionDefaults:
    """What the sessions of the scheme ``wire`` (None: ``ZROS_WIRE``, else the default) do
    where their settings say nothing."""
    return wire_class(chosen_wire(wire)).session


def session_config(
    connect: str | Sequence[str] | None = None,
    *,
    wire: str | None = None,
    **settings: Unpack[SessionOptions],
) -> TransportConfig:
    """The settings of a session for the scheme ``wire`` (None: ``ZROS_WIRE``, else the
    default): ``TransportConfig.create`` with the scheme's session defaults."""
    from zros.transport import TransportConfig  # noqa: PLC0415 (lazy: `zros --help` imports this)

    return TransportConfig.create(connect, defaults=session_defaults(wire), **settings)


def any_type_key(wire: str, key: str) -> str:
    """The key expression matching every type on ``key`` as the graph shows it for ``wire``."""
    return wire_class(wire).any_type_key(key)


__all__ = [
    'DEFAULT_WIRE',
    'SCHEMES',
    'BridgeInfo',
    'BridgeWire',
    'Endpoint',
    'KeyScheme',
    'Requests',
    'RmwZenohWire',
    'Scheme',
    'SequenceNumbers',
    'TokenView',
    'Wire',
    'WireEntity',
    'WireOption',
    'WireSetting',
    'any_type_key',
    'ask_bridge',
    'bridges_at_start',
    'check_wire',
    'chosen_wire',
    'open_wire',
    'query_bridges',
    'read_attachment',
    'scheme_settings',
    'session_config',
    'session_defaults',
    'wire_class',
]
