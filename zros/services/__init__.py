"""Services: a server is a queryable, a call is a query (through a bridge or under rmw_zenoh).

Payloads are a CDR header and the request or response body (the bridge adds and strips the DDS
request id). A server answers each query exactly once; handlers run on the thread that spins the
node (async handlers on its event loop). A client's ``call`` waits on Zenoh's reply channel
directly, so the caller's node needs no spinning; the server's does (a call inside a callback of
the node that serves it times out, with an error that says why).
"""

from zros.runtime.futures import ServiceFuture
from zros.services.client import Client
from zros.services.errors import (
    BRIDGE_TIMEOUT,
    ERROR_PREFIX,
    MAX_PENDING,
    LinkLostError,
    ServiceCallError,
    ServiceError,
    ServiceTimeoutError,
    ServiceUnavailableError,
)
from zros.services.server import Service

__all__ = [
    'BRIDGE_TIMEOUT',
    'ERROR_PREFIX',
    'MAX_PENDING',
    'Client',
    'LinkLostError',
    'Service',
    'ServiceCallError',
    'ServiceError',
    'ServiceFuture',
    'ServiceTimeoutError',
    'ServiceUnavailableError',
]
