"""What a service's client and server are made of alike: its type and name, placed on the wire."""

from __future__ import annotations

from typing import TYPE_CHECKING

from zros.cdr.interfaces import ServiceType
from zros.cdr.message import Message
from zros.cdr.registry import registry_of
from zros.keyexpr.kinds import EntityKind
from zros.runtime.entity import Entity
from zros.services.errors import service_type

if TYPE_CHECKING:
    from zros.wire import WireEntity


class ServiceEntity(Entity):
    """A service's client or server: :meth:`_place_service` sets what both know of it."""

    srv_type: ServiceType
    type_name: str  #: ``pkg/srv/Name``
    Request: type[Message]
    Response: type[Message]
    name: str  #: resolved

    def _place_service(
        self, kind: EntityKind, name: str, srv_type: str | ServiceType, announce: bool
    ) -> WireEntity:
        """Resolve ``srv_type`` and ``name``; the ``kind`` end's own place on the wire."""
        self.srv_type = service_type(self.context.registry, srv_type)
        self.type_name = self.srv_type.__srvtype__
        self.Request = self.srv_type.Request
        self.Response = self.srv_type.Response
        self.name = self._resolve(kind, name)
        return self._place(
            kind, self.name, self.type_name, registry_of(self.Request), announce=announce, own=True
        )
