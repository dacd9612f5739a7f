"""Say why a session could not reach its router, where Zenoh only says "Unable to connect".

Probes each endpoint the way Zenoh would reach it: a TCP connection, then for ``tls/`` endpoints a
TLS handshake with the configured CA and client certificate. Each probe takes at most a couple of
seconds and talks only to the endpoint the user configured.
"""

from __future__ import annotations

import contextlib
import socket
import ssl

from zros.transport.config import DEFAULT_ENDPOINT, TransportConfig
from zros.transport.endpoints import EndpointError, parse_endpoint
from zros.transport.tlsfiles import check_tls_files

PROBE_TIMEOUT = 2.0


def _tls_problem(config: TransportConfig, host: str, port: int) -> str | None:
    tls = config.tls
    if tls is None:
        return (
            f'tls/{host}:{port} is a TLS endpoint but no CA certificate is configured: '
            'pass tls=zros.transport.Tls("ca.pem")'
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
        return (
            f'the certificate of {host}:{port} does not verify against '
            f'{tls.root_ca_certificate} ({exc.verify_message}): is it the CA that signed the '
            "router's certificate, and does the certificate name this host?"
        )
    except ssl.SSLError as exc:
        reason = exc.reason or str(exc)
        if 'CERTIFICATE_REQUIRED' in reason.upper() or 'HANDSHAKE_FAILURE' in reason.upper():
            if tls.certificate is None:
                return (
                    f'{host}:{port} requires a client certificate (mutual TLS): pass '
                    'Tls(ca, certificate=..., private_key=...)'
                )
            return f'{host}:{port} rejected the client certificate {tls.certificate} ({reason})'
        if 'UNKNOWN_CA' in reason.upper() or 'BAD_CERTIFICATE' in reason.upper():
            return f'{host}:{port} rejected the client certificate {tls.certificate} ({reason})'
        return f'the TLS handshake with {host}:{port} failed ({reason})'
    except OSError:
        return None
    return None


def explain_unreachable(config: TransportConfig) -> str:
    """The most likely reason the configured endpoints refused the session."""
    endpoints = list(config.connect or ([] if config.config_file else [DEFAULT_ENDPOINT]))
    reasons = []
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
            reasons.append(f'cannot resolve the host {host!r} of {endpoint}')
            continue
        except ConnectionRefusedError:
            here = ' (on this machine, `zros router` runs one)' if parsed.loopback else ''
            reasons.append(f'nothing listens at {endpoint}{here}')
            continue
        except OSError:
            reasons.append(f'no answer from {endpoint} within {PROBE_TIMEOUT:g} s (a firewall?)')
            continue
        if protocol == 'tls':
            problem = _tls_problem(config, host, port)
            if problem:
                reasons.append(problem)
                continue
        if config.user is not None:
            reasons.append(
                f'{endpoint} answers but refused the session: is the user {config.user!r} and '
                'its password right?'
            )
        else:
            reasons.append(
                f'{endpoint} answers but refused the session: does it require a user and '
                'password (user=, password=), TLS, or another Zenoh version?'
            )
    return '; '.join(reasons)
