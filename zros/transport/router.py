"""A Zenoh router inside this process, for demos and tests (no zenohd, no bridge needed)."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, TypedDict

from zros.closing import Closing
from zros.transport.credentials import check_user, password_dictionary, secret_values
from zros.transport.endpoints import normalize, parse_endpoint
from zros.transport.errors import TransportError, zenoh_reason
from zros.transport.session import _install_exit_hook, _open
from zros.transport.tlsfiles import check_tls_files

if TYPE_CHECKING:
    from typing_extensions import Unpack

    from zros.cdr.model import JsonValue


def _tls_settings(
    listen: Sequence[str], certificate: str | None, private_key: str | None, client_ca: str | None
) -> dict[str, JsonValue]:
    """Zenoh settings for TLS listeners with ``certificate``; clients verified by ``client_ca``."""
    if certificate is None and private_key is None and client_ca is None:
        return {}  # plain, or TLS by raw Zenoh settings
    tls = [e for e in listen if parse_endpoint(e).protocol in ('tls', 'quic')]
    if certificate is None or private_key is None:
        raise TransportError('a TLS router needs both its certificate and its private key')
    if len(tls) != len(listen):
        plain = next(e for e in listen if e not in tls)
        raise TransportError(
            f'a router with TLS files listens on tls/ endpoints only, not {plain}: anyone '
            'could connect there without them'
        )
    check_tls_files(client_ca, certificate, private_key)
    settings: dict[str, JsonValue] = {
        'transport/link/tls/listen_certificate': certificate,
        'transport/link/tls/listen_private_key': private_key,
    }
    if client_ca is not None:
        settings['transport/link/tls/root_ca_certificate'] = client_ca
        settings['transport/link/tls/enable_mtls'] = True
    return settings


#: bytes from which a message is large: sent on with ``block_first`` by zros routers (below)
LARGE_PAYLOAD = 65536
#: what zros routers do to large messages (64 KiB on) sent with congestion control ``drop``
#: (rmw_zenoh's and zros's default but for keep-all; the bridge's for best effort) as they
#: leave: ``block_first``, so that the newest of them still crosses a congested link whole
#: (under ``drop`` none does), and those at Zenoh's default priority go as ``data_low``, so that
#: small messages overtake them; a sender's other choices stay (docs/connecting.md)
LARGE_PAYLOADS: list[JsonValue] = [
    {
        'id': 'zros_large_payloads_last',
        'messages': ['put'], 'flows': ['egress'], 'payload_size': f'{LARGE_PAYLOAD}..',
        'qos': {'congestion_control': 'drop', 'priority': 'data'},
        'overwrite': {'congestion_control': 'block_first', 'priority': 'data_low'},
    },
    {
        'id': 'zros_large_payloads_block_first',
        'messages': ['put'], 'flows': ['egress'], 'payload_size': f'{LARGE_PAYLOAD}..',
        'qos': {'congestion_control': 'drop'},
        'overwrite': {'congestion_control': 'block_first'},
    },
]  # fmt: skip


def downsampling(rates: Mapping[str, float]) -> list[JsonValue]:
    """Zenoh's downsampling settings sending each topic of ``rates`` (a ROS name, Zenoh's ``*``
    and ``**`` allowed) at most that many times a second out of each link, on both wires
    (the bridge's key ``name``, rmw_zenoh's ``<domain>/name/<type>/<hash>``)."""
    rules: list[JsonValue] = []
    for topic, rate in rates.items():
        name = topic.strip('/')
        if not name or '//' in name or not rate > 0:
            raise TransportError(
                f'cannot downsample {topic!r} to {rate} Hz: give /topic=HZ, HZ > 0'
            )
        rules += [{'key_expr': name, 'freq': rate}, {'key_expr': f'*/{name}/**', 'freq': rate}]
    return [{'id': 'zros_downsample', 'messages': ['put'], 'flows': ['egress'], 'rules': rules}]


class RouterOptions(TypedDict, total=False):
    """The keywords of :class:`Router` (for :func:`start_router`)."""

    shared_memory: bool
    large_payloads: bool
    downsample: Mapping[str, float] | None
    zenoh: dict[str, JsonValue] | None
    certificate: str | None
    private_key: str | None
    client_ca: str | None
    user: str | None
    password: str | None


class Router(Closing):
    """A Zenoh router listening on ``listen`` (port 0 picks a free port; read ``endpoint``).

    Multicast scouting is off; shared memory is off unless asked, so clients behave as across
    a network. With ``certificate`` and ``private_key`` it listens on TLS (``tls/`` endpoints
    only); with ``client_ca`` too, clients must present a certificate that CA signed (mutual
    TLS); with ``user`` and ``password``, they must present those. ``large_payloads`` applies
    :data:`LARGE_PAYLOADS` (``zros router`` does by default: for a robot's router with a slow
    link; it drops large messages of a burst faster than even a local link takes them);
    ``downsample`` maps topics to the most messages a second each link gets of them
    (:func:`downsampling`).
    """

    def __init__(
        self,
        listen: Sequence[str] = ('tcp/127.0.0.1:0',),
        *,
        shared_memory: bool = False,
        large_payloads: bool = False,
        downsample: Mapping[str, float] | None = None,
        zenoh: dict[str, JsonValue] | None = None,
        certificate: str | None = None,
        private_key: str | None = None,
        client_ca: str | None = None,
        user: str | None = None,
        password: str | None = None,
    ) -> None:
        import zenoh as z  # noqa: PLC0415 (lazy: Zenoh, only for a session)

        listen = [normalize(endpoint) for endpoint in listen]
        if user is not None:
            check_user(user, password)
        settings: dict[str, JsonValue] = {
            'mode': 'router',
            'listen': {'endpoints': list(listen)},
            'scouting': {'delay': 0, 'multicast': {'enabled': False}},
            'adminspace': {'enabled': True},
            'timestamping': {'enabled': True},
            'transport': {'shared_memory': {'enabled': shared_memory}},
        }
        if large_payloads:
            settings['qos'] = {'network': LARGE_PAYLOADS}
        if downsample:
            settings['downsampling'] = downsampling(downsample)
        config = z.Config.from_json5(json.dumps(settings))
        extra = {**_tls_settings(listen, certificate, private_key, client_ca), **(zenoh or {})}
        secrets = [password, *secret_values(extra)]
        try:
            for key, value in extra.items():
                config.insert_json5(key, json.dumps(value))
            with password_dictionary(config, user, password):
                self.session: z.Session = z.open(config)
        except z.ZError as exc:
            reason = zenoh_reason(exc, secrets)
            where = ', '.join(listen)
            if 'Address already in use' not in reason:
                raise TransportError(f'cannot start a router on {where}: {reason}') from None
            taken = (
                f'cannot start a router on {where}: the port is taken (another router or bridge?'
            )
            failure = TransportError(f'{taken} listen on another port, or port 0 for a free one)')
            failure.command_line = f'{taken} `zros doctor --connect` it, or --listen elsewhere)'
            raise failure from None
        self.zid = str(self.session.zid())
        self.endpoints = self._locators()
        self._closed = False
        _install_exit_hook()
        _open.add(self)  # type: ignore[arg-type]  # closed at exit as sessions are

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
            _open.discard(self)  # type: ignore[arg-type]  # as above
            self.session.close()  # type: ignore[no-untyped-call]  # untyped in zenoh's stub

    def __repr__(self) -> str:
        return f'<zros Router {self.endpoint}{" (closed)" if self._closed else ""}>'


def start_router(
    listen: str | Sequence[str] = 'tcp/127.0.0.1:0', **options: Unpack[RouterOptions]
) -> Router:
    """Start a router inside this process; ``router.endpoint`` is where clients connect.

    ``options``: those of :class:`Router` (TLS files, user and password, raw Zenoh settings).
    """
    return Router([listen] if isinstance(listen, str) else listen, **options)
