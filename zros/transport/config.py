"""How a zros process reaches the Zenoh network: settings from arguments, environment and files.

Precedence, highest first: arguments, environment (``ZROS_CONNECT``, ``ZROS_LISTEN``,
``ZROS_MODE``, ``ZROS_TLS_CA``/``_CERTIFICATE``/``_KEY``, ``ZROS_USER``/``ZROS_PASSWORD``), the
json5 file named by ``config`` or ``ZENOH_CONFIG``, then zros's defaults: client mode connecting
to the local bridge at ``tcp/127.0.0.1:7447``, multicast scouting off, timestamping on
(transient-local publishers need it). Endpoints may omit ``tcp/`` (``robot:7447``).

A peer listens on loopback (``tcp/127.0.0.1:0``) unless ``listen`` (``ZROS_LISTEN``, the file)
names other endpoints. What listens is held to the node's own settings: with ``tls`` only on
``tls/`` endpoints, with the node's certificate, clients verified against its CA; with a user,
only connections that present the same user and password are accepted.

A wire scheme may have session defaults of its own (:class:`SessionDefaults`, passed as
``defaults``): another mode, router and listening endpoint, and variables naming the file and
overrides of single settings. This module knows no scheme: ``zros.wire.session_config`` gives
each scheme's defaults.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict

from zros.errors import SettingError
from zros.transport.credentials import HIDDEN, check_user, key_file_secrets, redact, secret_values
from zros.transport.endpoints import normalize, parse_endpoint
from zros.transport.errors import TransportError, zenoh_reason
from zros.transport.tlsfiles import require_file

if TYPE_CHECKING:
    from typing_extensions import Unpack
    from zenoh import Config as ZenohConfig

    from zros.cdr.model import JsonValue

#: zenoh-bridge-ros2dds and zenohd listen here by default
DEFAULT_ENDPOINT = 'tcp/127.0.0.1:7447'
#: where a peer listens unless told otherwise: this machine only
PEER_LISTEN = 'tcp/127.0.0.1:0'
MODES = ('client', 'peer')


@dataclass(frozen=True)
class SessionDefaults:
    """What a session does where its settings say nothing: a wire scheme's defaults (these,
    zenoh-bridge-ros2dds's and zenohd's, unless ``zros.wire`` gives a scheme's own)."""

    mode: str = 'client'
    connect: str = DEFAULT_ENDPOINT  #: where to connect when no endpoints are given
    peer_connects: bool = False  #: whether a peer connects there too (else only a client)
    listen: str = PEER_LISTEN  #: where a peer listens (``tls/`` for ``tcp/`` with TLS)
    #: the variable naming the configuration file, before ``ZENOH_CONFIG``
    config_file_variable: str | None = None
    #: the variable holding ``path=json5;...`` overrides of single settings
    override_variable: str | None = None


def parse_override(text: str, variable: str) -> list[tuple[str, str]]:
    """Overrides of single settings from the variable ``variable``: ``path=json5`` items
    separated by ``;`` (outside brackets and quotes)."""
    items: list[str] = []
    depth, quote, start = 0, '', 0
    for index, char in enumerate(text):
        if quote:
            quote = '' if char == quote else quote
        elif char in '"\'':
            quote = char
        elif char in '[{':
            depth += 1
        elif char in ']}':
            depth -= 1
        elif char == ';' and depth == 0:
            items.append(text[start:index])
            start = index + 1
    items.append(text[start:])
    pairs = []
    for item in filter(str.strip, items):
        key, equals, value = item.partition('=')
        if not equals or not key.strip() or not value.strip():
            raise SettingError(f'{variable} item {item!r} is not path=json5')
        pairs.append((key.strip(), value.strip()))
    return pairs


def _endpoints(value: str | Sequence[str] | None) -> tuple[str, ...] | None:
    """Endpoints from a list or comma-separated text, checked (``host:port`` gets ``tcp/``)."""
    if value is None:
        return None
    items = value.split(',') if isinstance(value, str) else list(value)
    return tuple(normalize(item) for item in items if item.strip())


def listen_endpoints(config: ZenohConfig) -> list[str]:
    """The endpoints a ``zenoh.Config`` listens on in its mode (per-mode lists resolved)."""
    mode = json.loads(config.get_json('mode')) or 'peer'
    endpoints = json.loads(config.get_json('listen/endpoints')) or []
    if isinstance(endpoints, dict):
        endpoints = endpoints.get(mode) or []
    return [str(endpoint) for endpoint in endpoints]


#: how long (µs) a ``drop`` message in fragments may wait for room before Zenoh drops it
FRAGMENTS_WAIT = 'transport/link/tx/queue/congestion_control/drop/max_wait_before_drop_fragments'


def _zenoh_default(config: ZenohConfig, key: str) -> bool:
    """Whether ``config`` has Zenoh's default value for ``key`` (nobody set it)."""
    import zenoh  # noqa: PLC0415 (lazy: Zenoh, only for a session)

    return bool(config.get_json(key) == zenoh.Config().get_json(key))


@dataclass(frozen=True)
class Tls:
    """TLS files: the CA that signed the router's certificate, and for mutual TLS our own pair.

    A peer also listens with its own pair, verifying who connects against the CA.
    """

    root_ca_certificate: str
    certificate: str | None = None  #: our certificate, for mutual TLS
    private_key: str | None = None  #: its private key
    verify_name: bool = True  #: check that the router's certificate names the host we dial

    def __post_init__(self) -> None:
        if (self.certificate is None) != (self.private_key is None):
            raise SettingError(
                'mutual TLS needs both a certificate and a private key: '
                'Tls(ca, certificate=..., private_key=...)'
            )
        require_file(self.root_ca_certificate, 'CA certificate')
        require_file(self.certificate, 'certificate')
        require_file(self.private_key, 'private key')


class SettingOptions(TypedDict, total=False):
    """The settings of a session beyond its endpoints, mode and file (``TransportConfig``'s)."""

    multicast_scouting: bool
    shared_memory: bool | None
    tls: Tls | None
    user: str | None
    password: str | None
    zenoh: dict[str, JsonValue]
    wait_for_router: bool


class ConfigOptions(SettingOptions, total=False):
    """The keywords of :meth:`TransportConfig.create` beyond its named parameters."""

    defaults: SessionDefaults


class SessionOptions(SettingOptions, total=False):
    """The session settings a node passes on to :meth:`TransportConfig.create`."""

    listen: str | Sequence[str] | None
    mode: str | None
    config_file: str | os.PathLike[str] | None


@dataclass(frozen=True, repr=False)
class TransportConfig:
    """The Zenoh session settings of a zros process (see the module docstring for defaults).

    ``zenoh`` holds raw Zenoh settings as ``{"path/of/key": value}``, applied last. The
    password and secret ``zenoh`` values never show in its ``repr``.
    """

    connect: tuple[str, ...] | None = None
    listen: tuple[str, ...] | None = None
    mode: str | None = None
    config_file: str | None = None
    multicast_scouting: bool = False
    shared_memory: bool | None = None  #: None: Zenoh's default (on)
    tls: Tls | None = None
    user: str | None = None
    password: str | None = None
    zenoh: dict[str, JsonValue] = field(default_factory=dict)
    defaults: SessionDefaults = SessionDefaults()  #: what applies where nothing is set
    #: True: a peer whose ``connect`` endpoints cannot be reached fails at open, as a client
    #: does; False: it opens and Zenoh keeps trying (a warning at most every 10 s says why)
    wait_for_router: bool = True

    def __post_init__(self) -> None:
        for name in ('connect', 'listen'):
            endpoints = getattr(self, name)
            if endpoints is not None:
                object.__setattr__(self, name, _endpoints(endpoints))
        if self.user is not None:
            check_user(self.user, self.password)

    def __repr__(self) -> str:
        shown = []
        for name in self.__dataclass_fields__:
            value = getattr(self, name)
            if name == 'password' and value is not None:
                value = HIDDEN
            elif name == 'zenoh':
                value = redact(value)
            shown.append(f'{name}={value!r}')
        return f'TransportConfig({", ".join(shown)})'

    def secrets(self) -> list[str]:
        """What must never be shown: the password, secret raw settings, private key content."""
        found = [self.password] if self.password else []
        found += secret_values(self.zenoh)
        if self.tls is not None:
            found += key_file_secrets(self.tls.private_key)
        return found

    @classmethod
    def create(
        cls,
        connect: str | Sequence[str] | None = None,
        listen: str | Sequence[str] | None = None,
        mode: str | None = None,
        config_file: str | os.PathLike[str] | None = None,
        **options: Unpack[ConfigOptions],
    ) -> TransportConfig:
        """Settings from arguments, falling back on the environment for what is not given."""
        env = os.environ
        if 'tls' not in options and env.get('ZROS_TLS_CA'):
            certificate, key = env.get('ZROS_TLS_CERTIFICATE'), env.get('ZROS_TLS_KEY')
            if (certificate is None) != (key is None):
                raise SettingError('set ZROS_TLS_CERTIFICATE and ZROS_TLS_KEY together, or neither')
            options['tls'] = Tls(env['ZROS_TLS_CA'], certificate, key)
        elif 'tls' not in options and (env.get('ZROS_TLS_CERTIFICATE') or env.get('ZROS_TLS_KEY')):
            # a client certificate without the CA that checks the router would be ignored, and
            # the session would try plain TCP: say what is missing instead
            raise SettingError(
                'ZROS_TLS_CERTIFICATE and ZROS_TLS_KEY need ZROS_TLS_CA (the CA certificate '
                "that signed the router's): set it too"
            )
        if 'user' not in options and env.get('ZROS_USER'):
            if 'password' not in options and env.get('ZROS_PASSWORD') is None:
                raise SettingError('ZROS_USER needs ZROS_PASSWORD: set it too')
            options['user'] = env['ZROS_USER']
            options.setdefault('password', env.get('ZROS_PASSWORD'))
        if 'wire' in options:
            raise TypeError(
                'TransportConfig.create takes the session defaults of a wire scheme, not its '
                "name: zros.wire.session_config(wire='...') makes the settings of a scheme"
            )
        if 'defaults' not in options and env.get('ZROS_WIRE'):
            # this layer knows no scheme: say so rather than give another scheme's session
            warnings.warn(
                'ZROS_WIRE is set, but TransportConfig.create() and Transport() take no wire '
                'scheme: zros.wire.session_config() makes the settings of the one it names',
                stacklevel=2,
            )
        variable = options.get('defaults', SessionDefaults()).config_file_variable
        if not config_file and variable:
            config_file = env.get(variable)
        config = cls(
            connect=_endpoints(connect if connect is not None else env.get('ZROS_CONNECT')),
            listen=_endpoints(listen if listen is not None else env.get('ZROS_LISTEN')),
            mode=mode or env.get('ZROS_MODE'),
            config_file=str(config_file) if config_file else env.get('ZENOH_CONFIG'),
            **options,
        )
        if config.mode is not None and config.mode not in MODES:
            raise SettingError(f'mode must be "client" or "peer", got {config.mode!r}')
        return config

    def to_zenoh(self) -> ZenohConfig:
        """The ``zenoh.Config`` these settings describe (TransportError if Zenoh refuses one)."""
        import zenoh  # noqa: PLC0415 (lazy: Zenoh, only for a session)

        config = self._base()

        def unset(key: str) -> bool:
            return json.loads(config.get_json(key)) in (None, [], '')

        def put(key: str, value: JsonValue, text: str | None = None) -> None:
            try:
                config.insert_json5(key, json.dumps(value) if text is None else text)
            except zenoh.ZError as exc:
                reason = zenoh_reason(exc, self.secrets())
                raise TransportError(f'Zenoh refuses the setting {key}: {reason}') from None

        defaults = self.defaults
        if self.mode is not None or unset('mode'):
            put('mode', self.mode or defaults.mode)
        mode = json.loads(config.get_json('mode'))
        if self.connect is not None:
            put('connect/endpoints', list(self.connect))
        elif unset('connect/endpoints') and (mode == 'client' or defaults.peer_connects):
            put('connect/endpoints', [defaults.connect])
        if self.connect is not None and mode == 'peer' and self.wait_for_router:
            # a peer that cannot reach the router it was told of fails at open, as a client does
            # (Zenoh's peers open regardless and keep trying in the background)
            if _zenoh_default(config, 'connect/exit_on_failure'):
                put('connect/exit_on_failure', {'peer': True, 'client': True, 'router': False})
            if _zenoh_default(config, 'connect/timeout_ms'):
                put('connect/timeout_ms', {'peer': 0, 'client': 0, 'router': -1})
        if self.listen is not None:
            put('listen/endpoints', list(self.listen))
        elif mode == 'peer' and _zenoh_default(config, 'listen/endpoints'):
            loopback = defaults.listen
            put('listen/endpoints', [loopback.replace('tcp/', 'tls/') if self.tls else loopback])
        if not self.config_file or self.multicast_scouting:
            put('scouting/multicast/enabled', self.multicast_scouting)
        if self.shared_memory is not None:
            put('transport/shared_memory/enabled', self.shared_memory)
        put('timestamping/enabled', True)
        if unset('connect/retry'):
            # reconnect within a fraction of a second once a restarted router is back (Zenoh's
            # default backoff waits 1 to 4 s)
            put('connect/retry', {'period_init_ms': 100, 'period_max_ms': 1000,
                                  'period_increase_factor': 2})  # fmt: skip
        if _zenoh_default(config, FRAGMENTS_WAIT):
            # a large message a full link cannot take is dropped after 25 ms instead of 50: the
            # writer waits less, and loopback and LANs still take megabytes in that time
            put(FRAGMENTS_WAIT, 25_000)
        if self.tls is not None:
            put('transport/link/tls/root_ca_certificate', self.tls.root_ca_certificate)
            put('transport/link/tls/verify_name_on_connect', self.tls.verify_name)
            if self.tls.certificate is not None:
                put('transport/link/tls/enable_mtls', True)
                put('transport/link/tls/connect_certificate', self.tls.certificate)
                put('transport/link/tls/connect_private_key', self.tls.private_key)
        if self.user is not None:
            put('transport/auth/usrpwd/user', self.user)
            put('transport/auth/usrpwd/password', self.password)
        if defaults.override_variable:
            overrides = os.environ.get(defaults.override_variable, '')
            for key, text in parse_override(overrides, defaults.override_variable):
                put(key, None, text)
        for key, value in self.zenoh.items():
            put(key, value)
        if self.tls is not None:
            for key, value in self._tls_listener(listen_endpoints(config)).items():
                if unset(key):
                    put(key, value)
        return config

    def _base(self) -> ZenohConfig:
        """The configuration file's settings, or Zenoh's defaults."""
        import zenoh  # noqa: PLC0415 (lazy: Zenoh, only for a session)

        config: ZenohConfig  # the stubs' Self is lost on Python 3.10: name the type here
        if not self.config_file:
            config = zenoh.Config()
            return config
        path = Path(self.config_file)
        if not path.is_file():
            raise TransportError(f'the Zenoh configuration file {path} does not exist')
        try:
            config = zenoh.Config.from_file(str(path))
        except zenoh.ZError as exc:
            reason = zenoh_reason(exc, self.secrets())
            message = f'the Zenoh configuration file {path} is invalid: {reason}'
            raise TransportError(message) from None
        return config

    def _tls_listener(self, listening: list[str]) -> dict[str, JsonValue]:
        """What a node with TLS needs to listen on ``listening``: TLS endpoints only, and its
        own certificate for them (the CA and ``enable_mtls`` verify the clients)."""
        if not listening or self.tls is None:
            return {}
        for endpoint in listening:
            if parse_endpoint(endpoint).protocol not in ('tls', 'quic'):
                why = (
                    f'this node has TLS settings but would listen on {endpoint}, where anyone '
                    'connects without them: listen on tls/ endpoints only '
                )
                failure = TransportError(f'{why}(e.g. tls/127.0.0.1:0), or on none (listen=[])')
                failure.command_line = f'{why}(ZROS_LISTEN=tls/127.0.0.1:0)'
                raise failure
        if self.tls.certificate is None:
            why = (
                'a peer with TLS listens on TLS, and needs a certificate and key of its own for '
                'that; this one has only a CA certificate. '
            )
            failure = TransportError(
                f'{why}Pass Tls(ca, certificate, private_key) (zros.transport.pki.'
                "make_certificates makes them), connect as a client (mode='client'), or listen "
                'nowhere (listen=[]: it can then reach only peers that listen)'
            )
            failure.command_line = (
                f'{why}Set ZROS_TLS_CERTIFICATE and ZROS_TLS_KEY (`zros tls init` makes them), '
                'or connect as a client (--mode client)'
            )
            raise failure
        return {
            'transport/link/tls/listen_certificate': self.tls.certificate,
            'transport/link/tls/listen_private_key': self.tls.private_key,
        }

    def describe(self) -> str:
        """Where this configuration connects, for messages."""
        if self.connect:
            return ', '.join(self.connect)
        if self.config_file:
            return f'the endpoints of {self.config_file}'
        return self.defaults.connect
