"""Certificates for TLS between a robot's router and the machines that reach it, in one call.

A private CA signs one router certificate (naming every host or address clients dial) and one
client certificate per machine, for mutual TLS. A client certificate serves both ways and names
``localhost``, ``127.0.0.1`` and ``::1``, so that zros peers on one machine (which listen on
loopback, on TLS) accept each other's. Needs the ``cryptography`` package
(``pip install 'zros-client[tls]'``).
"""

from __future__ import annotations

import base64
import datetime
import ipaddress
import json
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from zros.transport.config import Tls
from zros.transport.errors import CertificateError
from zros.version import install_hint

if TYPE_CHECKING:
    from cryptography import x509
    from cryptography.hazmat.primitives.asymmetric.ec import EllipticCurvePrivateKey

    from zros.cdr.model import JsonValue

ROUTER = 'router'
#: the names a client's certificate carries for peers on its own machine
PEER_HOSTS = ('localhost', '127.0.0.1', '::1')


@dataclass(frozen=True)
class Certificates:
    """The files :func:`make_certificates` wrote, and the settings that use them."""

    folder: Path
    hosts: tuple[str, ...]
    clients: tuple[str, ...]

    @property
    def ca(self) -> Path:
        """The CA certificate every side trusts (``ca.key`` beside it signs new certificates)."""
        return self.folder / 'ca.pem'

    @property
    def router_certificate(self) -> Path:
        """The router's certificate."""
        return self.folder / f'{ROUTER}.pem'

    @property
    def router_key(self) -> Path:
        """The router's private key."""
        return self.folder / f'{ROUTER}.key'

    def client_certificate(self, name: str) -> Path:
        """The certificate of the client ``name``."""
        return self.folder / f'{self._client(name)}.pem'

    def client_key(self, name: str) -> Path:
        """The private key of the client ``name``."""
        return self.folder / f'{self._client(name)}.key'

    def _client(self, name: str) -> str:
        if name not in self.clients:
            raise CertificateError(f'no certificate for {name!r}; made for {list(self.clients)}')
        return name

    def client_tls(self, name: str | None = None, mutual: bool = True) -> Tls:
        """The ``tls=`` setting of a client: the CA, and its own pair for mutual TLS."""
        if not mutual:
            return Tls(str(self.ca))
        name = name or self.clients[0]
        return Tls(str(self.ca), str(self.client_certificate(name)), str(self.client_key(name)))

    def router_settings(self, mutual: bool = True) -> dict[str, JsonValue]:
        """Zenoh settings of the router, by path (``start_router(..., zenoh=...)``)."""
        settings: dict[str, JsonValue] = {
            'transport/link/tls/listen_certificate': str(self.router_certificate),
            'transport/link/tls/listen_private_key': str(self.router_key),
        }
        if mutual:
            settings['transport/link/tls/root_ca_certificate'] = str(self.ca)
            settings['transport/link/tls/enable_mtls'] = True
        return settings

    def router_config(self, listen: str = 'tls/[::]:7447', mutual: bool = True) -> str:
        """A json5 file for ``zenoh-bridge-ros2dds -c`` or ``zenohd -c`` on the robot.

        The certificates are inlined (base64), so this one file is all the robot needs; it holds
        the router's private key.
        """
        tls: dict[str, JsonValue] = {}
        for key, value in self.router_settings(mutual).items():
            setting = key.rpartition('/')[2]
            if isinstance(value, str):
                encoded = base64.b64encode(Path(value).read_bytes()).decode()
                tls[f'{setting}_base64'] = encoded
            else:
                tls[setting] = value
        config = {'listen': {'endpoints': [listen]}, 'transport': {'link': {'tls': tls}}}
        return json.dumps(config, indent=2) + '\n'


def _crypto() -> None:
    """CertificateError unless the cryptography package is installed."""
    try:
        import cryptography  # noqa: F401, PLC0415 (optional: the tls extra)
    except ImportError:
        raise CertificateError(
            f'making certificates needs the cryptography package: {install_hint("tls")}'
        ) from None


def _subject_names(hosts: Iterable[str]) -> list[x509.GeneralName]:
    _crypto()
    from cryptography import x509  # noqa: PLC0415 (optional: the tls extra)

    names: list[x509.GeneralName] = []
    for host in hosts:
        try:
            names.append(x509.IPAddress(ipaddress.ip_address(host.strip('[]'))))
        except ValueError:
            if not host or any(c.isspace() or c in '/:' for c in host):
                raise CertificateError(f'{host!r} is neither a host name nor an address') from None
            names.append(x509.DNSName(host))
    return names


def make_certificates(
    folder: str | os.PathLike[str],
    hosts: Sequence[str] = ('localhost', '127.0.0.1'),
    clients: Sequence[str] = ('laptop',),
    days: int = 365,
    overwrite: bool = False,
) -> Certificates:
    """Write a CA, a router certificate for ``hosts`` and a certificate per client into ``folder``.

    ``hosts`` are the names and addresses clients dial (``tls/<host>:7447``): the router's
    certificate must name each. Private keys are written readable by their owner only.
    """
    _crypto()
    from cryptography import x509  # noqa: PLC0415 (optional: the tls extra)
    from cryptography.hazmat.primitives import hashes, serialization  # noqa: PLC0415 (optional: the tls extra)
    from cryptography.hazmat.primitives.asymmetric import ec  # noqa: PLC0415 (optional: the tls extra)
    from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID  # noqa: PLC0415 (optional: the tls extra)

    if not hosts:
        raise CertificateError('name at least one host the router is reached at')
    if days < 1:
        raise CertificateError(f'certificates must be valid for at least a day, not {days}')
    for client in clients:
        if not re.fullmatch(r'[A-Za-z0-9][A-Za-z0-9_.-]*', client):
            raise CertificateError(f'client name {client!r}: use letters, digits, _ . -')
    if ROUTER in clients or 'ca' in clients or len(set(clients)) != len(clients):
        raise CertificateError(f'client names must be distinct and not "ca" or "{ROUTER}"')
    result = Certificates(Path(folder), tuple(hosts), tuple(clients))
    files = [result.ca, result.folder / 'ca.key', result.router_certificate, result.router_key]
    for client in clients:
        files += [result.client_certificate(client), result.client_key(client)]
    in_the_way = [str(path) for path in files if path.exists()]
    if in_the_way and not overwrite:
        failure = CertificateError(
            f'will not overwrite {", ".join(in_the_way)} (overwrite=True replaces them)'
        )
        failure.command_line = f'will not overwrite {", ".join(in_the_way)} (--force replaces them)'
        raise failure
    alternative_names = x509.SubjectAlternativeName(_subject_names(hosts))
    result.folder.mkdir(parents=True, exist_ok=True)

    now = datetime.datetime.now(datetime.timezone.utc)

    def name(common_name: str) -> x509.Name:
        return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])

    def builder(
        subject: str, key: EllipticCurvePrivateKey, issuer: x509.Name
    ) -> x509.CertificateBuilder:
        return (
            x509.CertificateBuilder()
            .subject_name(name(subject))
            .issuer_name(issuer)
            .public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - datetime.timedelta(minutes=5))
            .not_valid_after(now + datetime.timedelta(days=days))
        )

    def write_key(path: Path, key: EllipticCurvePrivateKey) -> None:
        data = key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
        descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(descriptor, 'wb') as file:
            file.write(data)

    def write_certificate(path: Path, certificate: x509.Certificate) -> None:
        path.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))

    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_usage = x509.KeyUsage(
        digital_signature=True,
        content_commitment=False,
        key_encipherment=False,
        data_encipherment=False,
        key_agreement=False,
        key_cert_sign=True,
        crl_sign=True,
        encipher_only=False,
        decipher_only=False,
    )
    ca_name = f'zros CA {result.folder.resolve().name}'
    ca = (
        builder(ca_name, ca_key, name(ca_name))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(ca_usage, critical=True)
        .sign(ca_key, hashes.SHA256())
    )
    write_certificate(result.ca, ca)
    write_key(result.folder / 'ca.key', ca_key)

    def leaf(
        file_stem: str,
        subject: str,
        usages: list[x509.ObjectIdentifier],
        names: x509.SubjectAlternativeName,
    ) -> None:
        key = ec.generate_private_key(ec.SECP256R1())
        certificate = (
            builder(subject, key, ca.subject)
            .add_extension(x509.ExtendedKeyUsage(usages), critical=False)
            .add_extension(names, critical=False)
        )
        write_certificate(
            result.folder / f'{file_stem}.pem', certificate.sign(ca_key, hashes.SHA256())
        )
        write_key(result.folder / f'{file_stem}.key', key)

    leaf(ROUTER, hosts[0], [ExtendedKeyUsageOID.SERVER_AUTH], alternative_names)
    # a client in peer mode also listens, on loopback (its peers on this machine dial it there)
    both = [ExtendedKeyUsageOID.CLIENT_AUTH, ExtendedKeyUsageOID.SERVER_AUTH]
    for client in clients:
        names = x509.SubjectAlternativeName(_subject_names([client, *PEER_HOSTS]))
        leaf(client, client, both, names)
    return result
