"""The Zenoh session of the process: configuration, opening and closing, an embedded router."""

from zros.transport.config import DEFAULT_ENDPOINT, Tls, TransportConfig
from zros.transport.errors import EndpointError, TlsFileError, TransportError
from zros.transport.router import Router, start_router
from zros.transport.session import Transport, close_default_transport, default_transport

__all__ = [
    'DEFAULT_ENDPOINT',
    'EndpointError',
    'Router',
    'Tls',
    'TlsFileError',
    'Transport',
    'TransportConfig',
    'TransportError',
    'close_default_transport',
    'default_transport',
    'start_router',
]
