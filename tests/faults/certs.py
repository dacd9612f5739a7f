"""Certificates ``zros tls init`` would never make: expired, client-only (as older zros made)."""

from __future__ import annotations

import datetime
import ipaddress
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from zros.transport import Router
from zros.transport.pki import Certificates


def by_name(router: Router) -> str:
    """The router's TLS endpoint by the name its certificate carries (``localhost``)."""
    return router.endpoint.replace('127.0.0.1', 'localhost')


def leaf(
    pki: Certificates,
    stem: Path,
    *,
    server: bool = True,
    valid_days: tuple[int, int] = (-1, 30),
) -> tuple[Path, Path]:
    """A certificate and key signed by ``pki``'s CA, naming localhost and 127.0.0.1.

    ``server``: whether it may serve TLS (a client-only certificate otherwise); ``valid_days``:
    its validity, in days from now.
    """
    ca_key = serialization.load_pem_private_key((pki.folder / 'ca.key').read_bytes(), None)
    ca = x509.load_pem_x509_certificate(pki.ca.read_bytes())
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.timezone.utc)
    usages = [ExtendedKeyUsageOID.CLIENT_AUTH] + ([ExtendedKeyUsageOID.SERVER_AUTH] * server)
    names = [x509.DNSName('localhost'), x509.IPAddress(ipaddress.ip_address('127.0.0.1'))]
    certificate = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, stem.name)]))
        .issuer_name(ca.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now + datetime.timedelta(days=valid_days[0]))
        .not_valid_after(now + datetime.timedelta(days=valid_days[1]))
        .add_extension(x509.ExtendedKeyUsage(usages), critical=False)
        .add_extension(x509.SubjectAlternativeName(names), critical=False)
        .sign(ca_key, hashes.SHA256())  # type: ignore[arg-type]
    )
    pem, key_file = stem.with_suffix('.pem'), stem.with_suffix('.key')
    pem.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
    key_file.write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    )
    return pem, key_file
