"""Where a gateway listens, as every gateway checks it: loopback unless told (a warning past
it), a port in range, and TLS from a PEM certificate and its key (``wss://``)."""

from __future__ import annotations

import ipaddress
import logging
import os
import ssl
from dataclasses import dataclass
from pathlib import Path

from zros.gateway.common.errors import GatewayError

_log = logging.getLogger('zros.gateway')


def is_loopback(address: str) -> bool:
    """Whether ``address`` is reachable from this machine only."""
    if address == 'localhost':
        return True
    try:
        return ipaddress.ip_address(address).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class Listen:
    """A gateway's listening socket: ``address`` (loopback by default; any other address logs a
    warning naming ``what`` listens), ``port`` (0: any free one), and optional TLS files."""

    port: int
    address: str = '127.0.0.1'
    tls_cert: str | os.PathLike[str] | None = None
    tls_key: str | os.PathLike[str] | None = None
    what: str = 'the gateway'

    @property
    def scheme(self) -> str:
        """``wss`` with TLS, else ``ws``."""
        return 'wss' if self.tls_cert else 'ws'

    def check(self) -> None:
        """Refuse a port out of range, half a TLS pair or a TLS file that cannot serve (named,
        as Zenoh's TLS files are); warn about an address reachable from the network."""
        if not 0 <= self.port <= 65535:
            raise GatewayError(f'the port must be 0 to 65535, not {self.port}')
        if (self.tls_cert is None) != (self.tls_key is None):
            raise GatewayError('TLS needs both a certificate and its private key')
        if self.tls_cert is not None and self.tls_key is not None:
            # the front's process uses Listen, and zros.transport loads Zenoh
            from zros.transport.errors import TlsFileError  # noqa: PLC0415 (no Zenoh in the front)
            from zros.transport.tlsfiles import check_tls_files  # noqa: PLC0415 (same)

            try:
                check_tls_files(None, os.fspath(self.tls_cert), os.fspath(self.tls_key))
            except TlsFileError as exc:
                raise GatewayError(f'{self.what}: {exc}') from None
        if not is_loopback(self.address):
            _log.warning(
                '%s listens on %s: anyone who reaches this machine there can see the robot%s',
                self.what,
                self.address,
                '' if self.tls_cert else ' (and the traffic is not encrypted: --tls-cert)',
            )

    def tls_files(self) -> tuple[bytes | None, bytes | None]:
        """The certificate and key bytes (None, None without TLS); GatewayError names a file
        that cannot be read."""
        if self.tls_cert is None or self.tls_key is None:
            return None, None
        files = []
        for what, path in (('certificate', self.tls_cert), ('private key', self.tls_key)):
            try:
                files.append(Path(path).read_bytes())
            except OSError as exc:
                raise GatewayError(f'cannot read the TLS {what} {path}: {exc.strerror}') from None
        return files[0], files[1]

    def ssl_context(self) -> ssl.SSLContext | None:
        """A server TLS context of the certificate and key (None without TLS)."""
        if self.tls_cert is None or self.tls_key is None:
            return None
        self.tls_files()  # names an unreadable file
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
        try:
            context.load_cert_chain(self.tls_cert, self.tls_key)
        except (ssl.SSLError, ValueError) as exc:
            raise GatewayError(
                f'the TLS certificate {self.tls_cert} and key {self.tls_key} are unusable: {exc}'
            ) from None
        return context

    def url(self, port: int) -> str:
        """The address clients open once listening on ``port``."""
        host = f'[{self.address}]' if ':' in self.address else self.address
        if host in ('0.0.0.0', '[::]', ''):
            host = 'localhost'
        return f'{self.scheme}://{host}:{port}'
