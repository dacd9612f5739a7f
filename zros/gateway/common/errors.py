"""The gateways' error: a gateway cannot start as asked, or a client's request cannot be
carried out."""

from __future__ import annotations

from zros.errors import ZrosError


class GatewayError(ZrosError):
    """A gateway cannot start as asked (a bad pattern, a port in use...) or a client's request
    cannot be carried out."""
