"""Say why a session could not reach its router, where Zenoh only says "Unable to connect".

Probes each endpoint the way Zenoh would reach it: a TCP connection, then for ``tls/`` endpoints a
TLS handshake with the configured CA and client certificate. Each probe takes at most a couple of
seconds and talks only to the endpoint the user configured.
"""

from __future__ import annotations

import contextlib
import socket
import ssl
from dataclasses import dataclass, field

from zros.transport.config import TransportConfig
from zros.transport.endpoints import parse_endpoint
from zros.transport.errors import EndpointError
from zros.transport.tlsfiles import check_tls_files

PROBE_TIMEOUT = 2.0


@dataclass(frozen=True)
class Reason:
    """Why one endpoint refused, for a program (``api``: arguments) and for a ``zros`` command's
    user (``cli``: flags and environment variables); ``unreachable``: nothing answered there."""

    api: str
    cli: str = ''
    unreachable: bool = False

    def __post_init__(self) -> None:
        if not self.cli:
            object.__setattr__(self, 'cli', self.api)


@dataclass(frozen=True)
class Diagnosis:
    """The reasons of every endpoint, joined for each reader."""

    reasons: list[Reason] = field(default_factory=list)

    @property
    def api(self) -> str:
        """For a program."""
        return '; '.join(r.api for r in self.reasons)

    @property
    def cli(self) -> str:
        """For a ``zros`` command's user."""
        return '; '.join(r.cli for r in self.reasons)

    @property
    def unreachable(self) -> bool:
        """Whether nothing answered at any endpoint (a router or bridge must be started)."""
        return bool(self.reasons) and all(r.unreachable for r in self.reasons)


def _tls_problem(config: TransportConfig, host: str, port: int) -> Reason | None:
    tls = config.tls
    if tls is None:
        problem = f'tls/{host}:{port} is a TLS endpoint but no CA certificate is configured: '
        return Reason(
            problem + 'pass tls=zros.transport.Tls("ca.pem")', problem + 'set ZROS_TLS_CA'
        )
    check_tls_files(tls.root_ca_certificate, tls.certificate, tls.private_key)
    context = ssl.create_default_context(cafile=tls.root_ca_certificate)
    context.check_hostname = tls.verify_name
    if not tls.verify_name:
        context.verify_mode = ssl.CERT_REQUIRED
    if tls.certificate and tls.private_key:
        context.load_cert_chain(tls.certificate, tls.private_key)
    try:
        with (
            socket.create_connection((host, port), timeout=PROBE_TIMEOUT) as raw,
            context.wrap_socket(raw, server_hostname=host) as secure,
        ):
            # with TLS 1.3 a server refuses a client certificate only after the handshake
            secure.settimeout(0.3)
            with contextlib.suppress(TimeoutError):
                secure.recv(1)
    except ssl.SSLCertVerificationError as exc:
        return Reason(
            f'the certificate of {host}:{port} does not verify against '
            f'{tls.root_ca_certificate} ({exc.verify_message}): is it the CA that signed the '
            "router's certificate, and does the certificate name this host?"
        )
    except ssl.SSLError as exc:
        reason = exc.reason or str(exc)
        if 'CERTIFICATE_REQUIRED' in reason.upper() or 'HANDSHAKE_FAILURE' in reason.upper():
            if tls.certificate is None:
                problem = f'{host}:{port} requires a client certificate (mutual TLS): '
                return Reason(
                    problem + 'pass Tls(ca, certificate=..., private_key=...)',
                    problem + 'set ZROS_TLS_CERTIFICATE and ZROS_TLS_KEY',
                )
            return Reason(
                f'{host}:{port} rejected the client certificate {tls.certificate} ({reason})'
            )
        if 'UNKNOWN_CA' in reason.upper() or 'BAD_CERTIFICATE' in reason.upper():
            return Reason(
                f'{host}:{port} rejected the client certificate {tls.certificate} ({reason})'
            )
        return Reason(f'the TLS handshake with {host}:{port} failed ({reason})')
    except OSError:
        return None
    return None


def explain_unreachable(config: TransportConfig) -> Diagnosis:
    """The most likely reason the configured endpoints refused the session."""
    endpoints = list(config.connect or ([] if config.config_file else [config.defaults.connect]))
    reasons: list[Reason] = []
    for endpoint in endpoints:
        try:
            parsed = parse_endpoint(endpoint)
        except EndpointError:
            continue
        protocol, host, port = parsed.protocol, parsed.host, parsed.port
        if port is None:
            continue
        try:
            with socket.create_connection((host, port), timeout=PROBE_TIMEOUT):
                pass
        except socket.gaierror:
            reasons.append(Reason(f'cannot resolve the host {host!r} of {endpoint}', '', True))
            continue
        except ConnectionRefusedError:
            nothing = f'nothing listens at {endpoint}'
            if parsed.loopback:
                reasons.append(
                    Reason(
                        f'{nothing} (on this machine, zros.transport.start_router() runs one)',
                        f'{nothing} (on this machine, `zros router` runs one)',
                        True,
                    )
                )
            else:
                reasons.append(Reason(nothing, '', True))
            continue
        except OSError:
            no_answer = f'no answer from {endpoint} within {PROBE_TIMEOUT:g} s (a firewall?)'
            reasons.append(Reason(no_answer, '', True))
            continue
        if protocol == 'tls':
            problem = _tls_problem(config, host, port)
            if problem:
                reasons.append(problem)
                continue
        if config.user is not None:
            reasons.append(
                Reason(
                    f'{endpoint} answers but refused the session: is the user {config.user!r} '
                    'and its password right?'
                )
            )
        else:
            refused = f'{endpoint} answers but refused the session: does it require a user and '
            reasons.append(
                Reason(
                    refused + 'password (user=, password=), TLS (tls=), or another Zenoh version?',
                    refused + 'password (ZROS_USER, ZROS_PASSWORD), TLS (ZROS_TLS_CA), or another '
                    'Zenoh version?',
                )
            )
    return Diagnosis(reasons)
