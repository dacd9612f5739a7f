"""What service servers and clients share: the errors, the error-reply prefix, the types."""

from __future__ import annotations

from zros.cdr import TypeRegistry
from zros.cdr.interfaces import ServiceType
from zros.errors import ZrosError

#: what a zenoh-bridge-ros2dds waits for a reply by default (``queries_timeout.default``)
BRIDGE_TIMEOUT = 5.0
#: requests a server holds before it refuses more (each answered with an error)
MAX_PENDING = 10_000
#: error replies of zros servers start with this, so clients can tell them from Zenoh's own
ERROR_PREFIX = 'zros service error: '


class ServiceError(ZrosError):
    """A service call failed."""


class ServiceUnavailableError(ServiceError):
    """No server answered: none exists for the service (or it went away during the call)."""


class ServiceTimeoutError(ServiceError, TimeoutError):
    """The server did not reply in time."""


class ServiceCallError(ServiceError):
    """The server replied with an error (its handler raised, or the request did not decode),
    or its reply does not decode."""


def service_type(registry: TypeRegistry, srv_type: str | ServiceType) -> ServiceType:
    """The service type of a name (``pkg/srv/Name`` or ``pkg/Name``) or a ServiceType."""
    if isinstance(srv_type, ServiceType):
        return srv_type
    found = registry.get_type(srv_type)
    if not isinstance(found, ServiceType):
        raise TypeError(f'{srv_type} is not a service type')
    return found
