"""The gateways' error, in a module of its own: the Foxglove front's process imports it
without the rest of the gateway (and so without Zenoh)."""

from __future__ import annotations

from zros.errors import ZrosError


class GatewayError(ZrosError):
    """A gateway cannot start as asked (a bad pattern, a port in use...) or a client's request
    cannot be carried out."""
