"""Check TLS files before Zenoh or Python's ``ssl`` reads them, so that a bad one is named.

Left to themselves, Zenoh says "Unable to connect" and ``ssl`` says
``[X509: KEY_VALUES_MISMATCH]`` about files they do not name. Each check here raises a
:class:`TlsFileError` that names the file, its role, what is wrong and how to fix it. Expiry
and a certificate's usages are checked when the ``cryptography`` package (the ``tls`` extra) is
installed; the rest needs only the standard library.
"""

from __future__ import annotations

import datetime
import ipaddress
import re
import ssl
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from zros.transport.errors import TlsFileError

if TYPE_CHECKING:
    from cryptography.x509 import Certificate

#: how a program makes a matching set of TLS files, and how a ``zros`` command's user does
FIX = 'make a matching set with zros.transport.pki.make_certificates(folder)'
CLI_FIX = 'make a matching set with `zros tls init FOLDER`'
_BLOCK = re.compile(rb'-----BEGIN ([A-Z0-9 ]+)-----')


def _failure(before: str, after: str = '', api: str = FIX, cli: str = CLI_FIX) -> TlsFileError:
    """A TlsFileError saying ``before``, the fix for its reader (``api`` for a program,
    ``cli`` for a ``zros`` command's user), then ``after``."""
    failure = TlsFileError(f'{before}{api}{after}')
    failure.command_line = f'{before}{cli}{after}'
    return failure


def require_file(path: str | None, role: str) -> None:
    """``path`` names an existing file (TlsFileError otherwise)."""
    if path is not None and not Path(path).is_file():
        what = 'is a folder' if Path(path).is_dir() else 'does not exist'
        raise _failure(f'the {role} {path} {what}; ')


def _pem(path: str, role: str, wanted: str) -> bytes:
    """The file's bytes, if it holds a PEM block of the ``wanted`` kind."""
    require_file(path, role)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise TlsFileError(f'cannot read the {role} {path}: {exc.strerror}') from None
    if not data.strip():
        raise _failure(f'the {role} {path} is empty; ')
    kinds = [kind.decode() for kind in _BLOCK.findall(data)]
    if any(wanted in kind for kind in kinds):
        if 'ENCRYPTED' in ' '.join(kinds):
            raise _failure(
                f'the {role} {path} is encrypted with a passphrase, which Zenoh cannot read: '
                f'decrypt it (openssl pkey -in {path} -out plain.key), or '
            )
        return data
    if kinds:
        found = ', '.join(sorted(set(kinds))).lower()
        raise _failure(
            f'the {role} {path} holds a {found}, not a {wanted.lower()} (the wrong file?); '
        )
    if data[:1] == b'\x30':
        raise TlsFileError(
            f'the {role} {path} is DER (binary), Zenoh reads PEM: convert it with openssl '
            f'(x509 -inform der -in {path} -out {Path(path).stem}.pem)'
        )
    raise _failure(f'the {role} {path} is not a PEM file (no BEGIN {wanted} line); ')


def _certificate(path: str, role: str) -> Certificate | None:
    """Check a certificate file; its first certificate (a cryptography object) or None."""
    data = _pem(path, role, 'CERTIFICATE')
    try:
        ssl.create_default_context(cafile=path)
    except ssl.SSLError as exc:
        raise _failure(
            f'the {role} {path} cannot be read as a certificate ({exc.reason or exc}); '
        ) from None
    try:
        from cryptography import x509  # noqa: PLC0415 (optional: the tls extra)
    except ImportError:  # expiry and usages are checked with the tls extra only
        return None
    try:
        certificate = x509.load_pem_x509_certificate(data)
    except ValueError:
        return None  # ssl read it: leave the finer points to the handshake
    now = datetime.datetime.now(datetime.timezone.utc)
    if certificate.not_valid_after_utc < now:
        raise _failure(f'the {role} {path} expired on {certificate.not_valid_after_utc:%Y-%m-%d}; ')
    if certificate.not_valid_before_utc > now:
        raise TlsFileError(
            f'the {role} {path} is not valid before '
            f'{certificate.not_valid_before_utc:%Y-%m-%d %H:%M} UTC: is the clock of this '
            'machine right?'
        )
    return certificate


def _check_pair(certificate: str, key: str) -> None:
    _pem(key, 'private key', 'PRIVATE KEY')
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    try:
        context.load_cert_chain(certificate, key)
    except ssl.SSLError as exc:
        if 'KEY_VALUES_MISMATCH' in str(exc):
            raise _failure(
                f'the private key {key} does not belong to the certificate {certificate}: '
                'use the .key file made with that .pem; '
            ) from None
        raise _failure(
            f'the private key {key} cannot be used with the certificate {certificate} '
            f'({exc.reason or exc}); '
        ) from None


def _names(certificate: Certificate, host: str) -> bool:
    """Whether ``certificate``'s subject alternative names cover ``host``."""
    from cryptography import x509  # noqa: PLC0415 (optional: the tls extra)

    try:
        names = certificate.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return False
    try:
        return ipaddress.ip_address(host.strip('[]')) in names.get_values_for_type(x509.IPAddress)
    except ValueError:
        return host.lower() in {n.lower() for n in names.get_values_for_type(x509.DNSName)}


def first_named(path: str, hosts: Sequence[str]) -> str | None:
    """The first of ``hosts`` the certificate at ``path`` names (None: none, or unreadable)."""
    try:
        certificate = _certificate(path, 'certificate')
    except TlsFileError:
        return None
    if certificate is None:
        return None
    return next((host for host in hosts if _names(certificate, host)), None)


def _can_serve(certificate: Certificate, path: str, hosts: Sequence[str]) -> None:
    """A peer's certificate must be a server certificate for the hosts other peers dial."""
    from cryptography import x509  # noqa: PLC0415 (optional: the tls extra)
    from cryptography.x509.oid import ExtendedKeyUsageOID  # noqa: PLC0415 (optional: the tls extra)

    try:
        usages = certificate.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
    except x509.ExtensionNotFound:
        usages = None
    if usages is not None and ExtendedKeyUsageOID.SERVER_AUTH not in usages:
        raise _failure(
            f'the certificate {path} is for clients only, so other peers cannot accept it from '
            'a peer listening on TLS: make certificates with a current ',
            '',
            'make_certificates (its client certificates serve both ways), or connect as a '
            "client (mode='client')",
            '`zros tls init FOLDER` (its client certificates serve both ways), or connect as a '
            'client (--mode client)',
        )
    if not hosts:
        return
    for host in hosts:
        if not _names(certificate, host):
            names = '(client certificates name localhost, 127.0.0.1 and ::1)'
            raise _failure(
                f'the certificate {path} does not name {host}, where this peer listens, so '
                'other peers will refuse it: make certificates with a current ',
                '',
                f'zros.transport.pki.make_certificates {names}, or set verify_name=False on '
                'every peer',
                f'`zros tls init FOLDER` {names}, or listen at an address it names '
                '(ZROS_LISTEN=tls/127.0.0.1:0)',
            )


def check_tls_files(
    ca: str | None,
    certificate: str | None,
    private_key: str | None,
    listen_hosts: Sequence[str] | None = None,
) -> None:
    """Check a CA, a certificate and its key (any may be None); ``listen_hosts``: the hosts a
    peer listens on with this certificate, each of which it must name (None: not listening)."""
    if ca is not None:
        _certificate(ca, 'CA certificate')
    if certificate is None or private_key is None:
        return
    parsed = _certificate(certificate, 'certificate')
    _check_pair(certificate, private_key)
    if listen_hosts is not None and parsed is not None:
        _can_serve(parsed, certificate, listen_hosts)
