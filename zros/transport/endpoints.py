"""Zenoh endpoints as users type them: ``tcp/robot:7447``, or just ``robot:7447``.

Zenoh wants ``<protocol>/<address>[?<metadata>][#<config>]`` and answers anything else with a
JSON parser's error, or accepts a port of 99999 and fails later. Here an endpoint is checked
once, when the settings are made, and a bad one gets a one-line :class:`EndpointError` naming it
and the forms that work.
"""

from __future__ import annotations

import ipaddress
import re
from dataclasses import dataclass

from zros.transport.errors import EndpointError

#: protocols whose address is ``host:port``
IP_PROTOCOLS = ('tcp', 'tls', 'udp', 'quic', 'ws')
#: protocols whose address is a path, a name or a device
OTHER_PROTOCOLS = ('unixsock-stream', 'unixpipe', 'serial', 'vsock')
#: hosts that reach only this machine
LOOPBACK_NAMES = ('localhost', 'localhost.localdomain', 'ip6-localhost')

FORMS = (
    'write tcp/HOST:PORT, tls/HOST:PORT or HOST:PORT (tcp), e.g. tcp/192.168.1.5:7447 or [::1]:7447'
)
_HOST_NAME = re.compile(r'[A-Za-z0-9_]([A-Za-z0-9_.-]*[A-Za-z0-9_])?')


@dataclass(frozen=True)
class Endpoint:
    """A checked endpoint: ``protocol/host:port`` plus Zenoh's ``?metadata#config`` tail."""

    protocol: str
    host: str  #: a name, an IPv4 address, or an IPv6 address without brackets
    port: int | None  #: None for protocols without ports (unix sockets, serial)
    tail: str = ''

    def __str__(self) -> str:
        if self.port is None:
            return f'{self.protocol}/{self.host}{self.tail}'
        host = f'[{self.host}]' if ':' in self.host else self.host
        return f'{self.protocol}/{host}:{self.port}{self.tail}'

    @property
    def loopback(self) -> bool:
        """Whether only this machine can reach it (unix sockets and pipes included)."""
        if self.port is None:
            return self.protocol in ('unixsock-stream', 'unixpipe')
        if self.host.lower() in LOOPBACK_NAMES:
            return True
        try:
            return ipaddress.ip_address(self.host.split('%')[0]).is_loopback
        except ValueError:
            return False


def _bad(text: str, why: str) -> EndpointError:
    return EndpointError(f'bad endpoint {text!r}: {why}; {FORMS}')


def _host(text: str, address: str) -> tuple[str, str]:
    """Split ``host:port`` (``[v6]:port`` for IPv6) into host and port text."""
    if address.startswith('['):
        host, bracket, rest = address[1:].partition(']')
        if not bracket:
            raise _bad(text, 'an IPv6 address needs its closing "]"')
        try:
            ipaddress.ip_address(host.split('%')[0])
        except ValueError:
            raise _bad(text, f'{host!r} is not an IPv6 address') from None
        if not rest.startswith(':'):
            raise _bad(text, 'the port is missing')
        return host, rest[1:]
    if address.count(':') > 1:
        raise _bad(text, 'an IPv6 address goes in brackets, as [::1]:7447')
    host, colon, port = address.partition(':')
    if not host:
        raise _bad(text, 'the host is missing')
    if not _HOST_NAME.fullmatch(host):
        raise _bad(text, f'{host!r} is neither a host name nor an address')
    if not colon:
        raise _bad(text, 'the port is missing')
    return host, port


def parse_endpoint(text: str) -> Endpoint:
    """Check one endpoint; ``host:port`` means ``tcp/host:port``."""
    raw = text.strip()
    protocol, slash, rest = raw.partition('/')
    if not raw:
        raise _bad(text, 'it is empty')
    if not slash:
        protocol, rest = 'tcp', raw
    elif protocol.endswith(':') and rest.startswith('/'):
        raise _bad(text, 'an endpoint is not a URL (no "//")')
    protocol = protocol.lower()
    cut = min((i for i in (rest.find('?'), rest.find('#')) if i >= 0), default=len(rest))
    address, tail = rest[:cut], rest[cut:]
    if protocol in OTHER_PROTOCOLS:
        if not address:
            raise _bad(text, f'{protocol} needs an address after the "/"')
        return Endpoint(protocol, address, None, tail)
    if protocol not in IP_PROTOCOLS:
        known = ', '.join((*IP_PROTOCOLS, *OTHER_PROTOCOLS))
        raise _bad(text, f'unknown protocol {protocol!r} (Zenoh knows {known})')
    if address.startswith('/'):
        raise _bad(text, f'one "/" after the protocol, not "//" (write {protocol}/HOST:PORT)')
    host, port = _host(text, address)
    if not port.isdigit():
        raise _bad(text, f'the port {port!r} is not a number' if port else 'the port is missing')
    if int(port) > 65535:
        raise _bad(text, f'the port {port} is out of range (0 to 65535)')
    return Endpoint(protocol, host, int(port), tail)


def normalize(text: str) -> str:
    """``text`` as Zenoh wants it (``robot:7447`` -> ``tcp/robot:7447``); EndpointError if bad."""
    return str(parse_endpoint(text))
