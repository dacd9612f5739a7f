"""Which browsers may open a gateway: the ``Origin`` check both gateways apply to a WebSocket
upgrade.

A browser sends ``Origin`` with every WebSocket upgrade and lets any page open
``ws://localhost:PORT``, so listening on loopback does not keep a hostile page away from the
robot. Programs (rclpy tools, roslibpy, node clients) send no ``Origin`` and are not browsers:
they are accepted. A browser is accepted when its page comes from this machine (``localhost``,
``127.0.0.0/8``, ``[::1]``, any port or scheme) or from an origin the operator allowed.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from urllib.parse import urlsplit

from zros.gateway.common.listen import is_loopback

_log = logging.getLogger('zros.gateway')

#: allows every origin
ANY = '*'
#: the Foxglove web app, allowed by ``zros foxglove`` unless told otherwise
FOXGLOVE_APP = 'https://app.foxglove.dev'


def _normal(origin: str) -> str:
    """``scheme://host[:port]`` in lower case, without a trailing slash."""
    return origin.strip().rstrip('/').lower()


class OriginPolicy:
    """The origins a gateway accepts besides this machine's own pages.

    ``allowed`` holds origins as browsers send them (``https://example.com:8443``); ``'*'``
    accepts every origin. ``option`` names the setting that adds one, for the refusal's log line.
    """

    def __init__(self, allowed: Iterable[str] = (), option: str = '--allow-origin') -> None:
        self.allowed: frozenset[str] = frozenset(_normal(o) for o in allowed)
        self.option = option
        if ANY in self.allowed:
            _log.warning(
                'every web page may open this gateway (%s %s): a page on any site the operator '
                'visits can use the robot through it',
                option,
                ANY,
            )

    @property
    def any(self) -> bool:
        """Whether every origin is accepted."""
        return ANY in self.allowed

    def accepts(self, origin: str | None) -> bool:
        """Whether an upgrade carrying ``origin`` (None: no ``Origin`` header) is accepted."""
        if origin is None or self.any:
            return True
        normal = _normal(origin)
        if normal in self.allowed:
            return True
        host = urlsplit(normal).hostname
        return host is not None and is_loopback(host)

    def refuse(self, origin: str) -> str:
        """Log one line for a refused ``origin``; the reason to send with HTTP 403."""
        _log.warning(
            'refused a WebSocket upgrade from a page of %s; to allow it: %s %s',
            origin,
            self.option,
            _normal(origin),
        )
        return f'origin {origin} is not allowed by this gateway ({self.option} allows it)\n'

    def __repr__(self) -> str:
        return f'OriginPolicy({sorted(self.allowed)!r})'
