"""How a zros process reaches the Zenoh network: settings from arguments, environment and files.

Precedence, highest first: arguments, environment (``ZROS_CONNECT``, ``ZROS_LISTEN``,
``ZROS_MODE``, ``ZROS_TLS_CA``/``_CERTIFICATE``/``_KEY``, ``ZROS_USER``/``ZROS_PASSWORD``), the
json5 file named by ``config`` or ``ZENOH_CONFIG``, then zros's defaults: client mode connecting
to the local bridge at ``tcp/127.0.0.1:7447``, multicast scouting off, timestamping on
(transient-local publishers need it).

With ``wire='rmw_zenoh'`` (or ``ZROS_WIRE=rmw_zenoh``) the defaults are rmw_zenoh's own session
settings: a peer that connects to the ``rmw_zenohd`` router at ``tcp/localhost:7447`` and listens on
``tcp/localhost:0``, and rmw_zenoh's variables apply: ``ZENOH_SESSION_CONFIG_URI`` names the file,
``ZENOH_CONFIG_OVERRIDE="path=json5;path=json5"`` overrides single settings.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: zenoh-bridge-ros2dds and zenohd listen here by default
DEFAULT_ENDPOINT = 'tcp/127.0.0.1:7447'
#: where rmw_zenoh sessions find the rmw_zenohd router, and where they listen for peers
RMW_ZENOH_ENDPOINT = 'tcp/localhost:7447'
RMW_ZENOH_LISTEN = 'tcp/localhost:0'
MODES = ('client', 'peer')


def _wire(value: str | None) -> str | None:
    """None for the bridge (the default), 'rmw_zenoh' for rmw_zenoh's session defaults."""
    if value in (None, '', 'bridge'):
        return None
    if value != 'rmw_zenoh':
        raise ValueError(f'wire must be "bridge" or "rmw_zenoh", got {value!r}')
    return value


def parse_override(text: str) -> list[tuple[str, str]]:
    """``ZENOH_CONFIG_OVERRIDE``: ``path=json5`` items separated by ``;`` (outside brackets
    and quotes)."""
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
            raise ValueError(f'ZENOH_CONFIG_OVERRIDE item {item!r} is not path=json5')
        pairs.append((key.strip(), value.strip()))
    return pairs


def _endpoints(value: str | Sequence[str] | None) -> tuple[str, ...] | None:
    if value is None:
        return None
    items = value.split(',') if isinstance(value, str) else list(value)
    return tuple(item.strip() for item in items if item.strip())


@dataclass(frozen=True)
class Tls:
    """TLS files: the CA that signed the router's certificate, and for mutual TLS our own pair."""

    root_ca_certificate: str
    certificate: str | None = None  #: our certificate, for mutual TLS
    private_key: str | None = None  #: its private key
    verify_name: bool = True  #: check that the router's certificate names the host we dial

    def __post_init__(self) -> None:
        if (self.certificate is None) != (self.private_key is None):
            raise ValueError('mutual TLS needs both a certificate and a private key')
        for path in (self.root_ca_certificate, self.certificate, self.private_key):
            if path is not None and not Path(path).is_file():
                raise FileNotFoundError(f'TLS file {path} does not exist')


@dataclass(frozen=True)
class TransportConfig:
    """The Zenoh session settings of a zros process (see the module docstring for defaults).

    ``zenoh`` holds raw Zenoh settings as ``{"path/of/key": value}``, applied last.
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
    zenoh: dict[str, Any] = field(default_factory=dict)
    wire: str | None = None  #: 'rmw_zenoh': rmw_zenoh's session defaults (None: the bridge's)

    @classmethod
    def create(
        cls,
        connect: str | Sequence[str] | None = None,
        listen: str | Sequence[str] | None = None,
        mode: str | None = None,
        config_file: str | os.PathLike[str] | None = None,
        **options: Any,
    ) -> TransportConfig:
        """Settings from arguments, falling back on the environment for what is not given."""
        env = os.environ
        if 'tls' not in options and env.get('ZROS_TLS_CA'):
            options['tls'] = Tls(
                env['ZROS_TLS_CA'], env.get('ZROS_TLS_CERTIFICATE'), env.get('ZROS_TLS_KEY')
            )
        if 'user' not in options and env.get('ZROS_USER'):
            options['user'] = env['ZROS_USER']
            options.setdefault('password', env.get('ZROS_PASSWORD'))
        options['wire'] = _wire(options.get('wire') or env.get('ZROS_WIRE'))
        if not config_file and options['wire']:
            config_file = env.get('ZENOH_SESSION_CONFIG_URI')
        config = cls(
            connect=_endpoints(connect if connect is not None else env.get('ZROS_CONNECT')),
            listen=_endpoints(listen if listen is not None else env.get('ZROS_LISTEN')),
            mode=mode or env.get('ZROS_MODE'),
            config_file=str(config_file) if config_file else env.get('ZENOH_CONFIG'),
            **options,
        )
        if config.mode is not None and config.mode not in MODES:
            raise ValueError(f'mode must be "client" or "peer", got {config.mode!r}')
        if config.user is not None and config.password is None:
            raise ValueError('a user needs a password')
        return config

    def to_zenoh(self) -> Any:
        """The ``zenoh.Config`` these settings describe."""
        import zenoh

        if self.config_file:
            path = Path(self.config_file)
            if not path.is_file():
                raise FileNotFoundError(f'Zenoh configuration file {path} does not exist')
            config = zenoh.Config.from_file(str(path))
        else:
            config = zenoh.Config()

        def unset(key: str) -> bool:
            return json.loads(config.get_json(key)) in (None, [], '')

        def put(key: str, value: Any) -> None:
            config.insert_json5(key, json.dumps(value))

        rmw = self.wire == 'rmw_zenoh'
        if self.mode is not None or unset('mode'):
            put('mode', self.mode or ('peer' if rmw else 'client'))
        mode = json.loads(config.get_json('mode'))
        if self.connect is not None:
            put('connect/endpoints', list(self.connect))
        elif unset('connect/endpoints') and (mode == 'client' or rmw):
            put('connect/endpoints', [RMW_ZENOH_ENDPOINT if rmw else DEFAULT_ENDPOINT])
        if self.listen is not None:
            put('listen/endpoints', list(self.listen))
        elif rmw and mode == 'peer' and not self.config_file:
            put('listen/endpoints', [RMW_ZENOH_LISTEN])
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
        if rmw:
            for key, text in parse_override(os.environ.get('ZENOH_CONFIG_OVERRIDE', '')):
                config.insert_json5(key, text)
        for key, value in self.zenoh.items():
            put(key, value)
        return config

    def describe(self) -> str:
        """Where this configuration connects, for messages."""
        if self.connect:
            return ', '.join(self.connect)
        if self.config_file:
            return f'the endpoints of {self.config_file}'
        return RMW_ZENOH_ENDPOINT if self.wire else DEFAULT_ENDPOINT
