"""What service servers and clients share: the errors, the error-reply prefix, the types."""

from __future__ import annotations

from typing import TypeVar

from zros.cdr import TypeRegistry
from zros.cdr.interfaces import ActionType, ServiceType
from zros.errors import ZrosError
from zros.transport.errors import TransportError

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


class LinkLostError(ServiceUnavailableError, TransportError):
    """The session has no link to its router: a call waiting when the link dropped, or made
    while it is down, ends with this at once (Zenoh reconnects by itself)."""


class ServiceTimeoutError(ServiceError, TimeoutError):
    """The server did not reply in time."""


class ServiceCallError(ServiceError):
    """The server replied with an error (its handler raised, or the request did not decode),
    or its reply does not decode."""


Interface = TypeVar('Interface', ServiceType, ActionType)


def interface_type(
    registry: TypeRegistry, name: str | Interface, kind: type[Interface], what: str
) -> Interface:
    """The service or action type (``kind``, ``what`` in the error) of a name
    (``pkg/srv/Name``, ``pkg/action/Name`` or ``pkg/Name``), or ``name`` when it is one."""
    if isinstance(name, kind):
        return name
    found = registry.get_type(name) if isinstance(name, str) else name
    if not isinstance(found, kind):
        raise TypeError(f'{name} is not {what}')
    return found


def service_type(registry: TypeRegistry, srv_type: str | ServiceType) -> ServiceType:
    """The service type of a name (``pkg/srv/Name`` or ``pkg/Name``) or a ServiceType."""
    return interface_type(registry, srv_type, ServiceType, 'a service type')
