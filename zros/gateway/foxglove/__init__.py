"""The Foxglove gateway (live graph or a recording) for the Foxglove app and Lichtblick; its door
is :mod:`zros.foxglove`.

``server`` (:class:`FoxgloveGateway`, :func:`serve`) follows the graph and feeds the Foxglove
SDK's server (``sdk_listener`` hands it what clients ask, ``sim_time`` follows ``/clock``);
``sdk`` starts that server behind ``front`` (our listener: ``Origin``, both subprotocol names,
TLS, a byte bound per client; with ``handshake``, ``relay``, ``ws_frames``) and renders
schemas; ``calls`` (client publishing, services) and ``params`` (parameters) carry out what
clients ask; ``bag_server`` (:class:`BagGateway`) plays a recording; ``assets`` serves
``package://`` files. It imports :mod:`zros.gateway.common`, never another gateway.

The classes and ``serve`` load on first use here, so that one module of the folder (the front)
loads without the server.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zros.gateway.foxglove.bag_server import BagGateway
    from zros.gateway.foxglove.sdk import ServerOptions
    from zros.gateway.foxglove.server import FoxgloveGateway, serve

_HOMES = {
    'BagGateway': 'bag_server',
    'FoxgloveGateway': 'server',
    'ServerOptions': 'sdk',
    'serve': 'server',
}
__all__ = ['BagGateway', 'FoxgloveGateway', 'ServerOptions', 'serve']


def __getattr__(name: str) -> object:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    return getattr(importlib.import_module(f'{__name__}.{home}'), name)
