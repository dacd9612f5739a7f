"""The rosbridge v2 gateway (with rosapi) for roslibjs and roslibpy; its door is
:mod:`zros.rosbridge`.

``server`` (:class:`RosbridgeGateway`, :func:`serve`) runs the websockets server; per client,
``client`` reads and dispatches the ops and drains the outbox; ``topics``, ``calls`` (services)
and ``actions`` carry them out; ``conversion`` turns messages into rosbridge's JSON values and
back, ``frames`` encodes what is sent (JSON, CBOR, PNG, fragments); ``rosapi`` answers rosapi's
services from the graph. It imports :mod:`zros.gateway.common`, never another gateway.

``serve`` and ``RosbridgeGateway`` load on first use here, so that one module of the folder
loads without the server.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zros.gateway.rosbridge.server import RosbridgeGateway, serve

__all__ = ['RosbridgeGateway', 'serve']


def __getattr__(name: str) -> object:
    if name not in __all__:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    return getattr(importlib.import_module(f'{__name__}.server'), name)
