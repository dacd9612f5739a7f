"""A Zenoh router inside this process, for demos and tests (no zenohd, no bridge needed)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from zros.transport.session import TransportError, _install_exit_hook, _open


class Router:
    """A Zenoh router listening on ``listen`` (port 0 picks a free port; read ``endpoint``).

    Multicast scouting is off; shared memory is off unless asked, so clients behave as across
    a network.
    """

    def __init__(
        self,
        listen: Sequence[str] = ('tcp/127.0.0.1:0',),
        *,
        shared_memory: bool = False,
        zenoh: dict[str, Any] | None = None,
    ) -> None:
        import zenoh as z

        settings: dict[str, Any] = {
            'mode': 'router',
            'listen': {'endpoints': list(listen)},
            'scouting': {'delay': 0, 'multicast': {'enabled': False}},
            'adminspace': {'enabled': True},
            'timestamping': {'enabled': True},
            'transport': {'shared_memory': {'enabled': shared_memory}},
        }
        config = z.Config.from_json5(json.dumps(settings))
        for key, value in (zenoh or {}).items():
            config.insert_json5(key, json.dumps(value))
        try:
            self.session: Any = z.open(config)
        except z.ZError as exc:
            raise TransportError(f'cannot start a router on {", ".join(listen)}: {exc}') from None
        self.zid = str(self.session.zid())
        self.endpoints = self._locators()
        self._closed = False
        _install_exit_hook()
        _open.add(self)  # type: ignore[arg-type]

    def _locators(self) -> list[str]:
        for reply in self.session.get(f'@/{self.zid}/router'):
            if reply.ok is not None:
                return list(json.loads(reply.ok.payload.to_string())['locators'])
        raise TransportError('the router did not report its locators')

    @property
    def endpoint(self) -> str:
        """The first endpoint clients can connect to, e.g. ``tcp/127.0.0.1:40123``."""
        return self.endpoints[0]

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._closed

    def close(self) -> None:
        """Stop the router; clients connected to it lose their link."""
        if not self._closed:
            self._closed = True
            _open.discard(self)  # type: ignore[arg-type]
            self.session.close()

    def __enter__(self) -> Router:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f'<zros Router {self.endpoint}{" (closed)" if self._closed else ""}>'


def start_router(listen: str | Sequence[str] = 'tcp/127.0.0.1:0', **options: Any) -> Router:
    """Start a router inside this process; ``router.endpoint`` is where clients connect."""
    return Router([listen] if isinstance(listen, str) else listen, **options)
