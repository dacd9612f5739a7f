"""Service and action types: namespaces of the message classes they define."""

from __future__ import annotations

from typing import Protocol

from zros.cdr.message import Message
from zros.cdr.model import ActionDef, ServiceDef


class ClassRegistry(Protocol):
    """Where a service or action type finds the classes of its parts (a TypeRegistry)."""

    @property
    def has_service_events(self) -> bool:
        """Whether services define an ``_Event`` message (Iron and later)."""
        ...

    def get_class(self, name: str) -> type[Message]:
        """The class of a message type."""
        ...

    def get_service(self, name: str) -> ServiceType:
        """The service type of a service name."""
        ...


class ServiceType:
    """A service type: ``.Request``, ``.Response`` and (Iron and later) ``.Event`` classes."""

    def __init__(self, registry: ClassRegistry, definition: ServiceDef) -> None:
        self.__srvtype__ = definition.name
        self.definition = definition
        self.Request: type[Message] = registry.get_class(definition.name + '_Request')
        self.Response: type[Message] = registry.get_class(definition.name + '_Response')
        self.Event: type[Message] | None = (
            registry.get_class(definition.name + '_Event') if registry.has_service_events else None
        )

    def __repr__(self) -> str:
        return f'<service type {self.__srvtype__}>'


class ActionType:
    """An action type: ``.Goal``, ``.Result``, ``.Feedback``, ``.FeedbackMessage`` classes and
    the ``.SendGoal`` and ``.GetResult`` service types."""

    def __init__(self, registry: ClassRegistry, definition: ActionDef) -> None:
        name = definition.name
        self.__actiontype__ = name
        self.definition = definition
        self.Goal: type[Message] = registry.get_class(name + '_Goal')
        self.Result: type[Message] = registry.get_class(name + '_Result')
        self.Feedback: type[Message] = registry.get_class(name + '_Feedback')
        self.FeedbackMessage: type[Message] = registry.get_class(name + '_FeedbackMessage')
        self.SendGoal: ServiceType = registry.get_service(name + '_SendGoal')
        self.GetResult: ServiceType = registry.get_service(name + '_GetResult')

    def __repr__(self) -> str:
        return f'<action type {self.__actiontype__}>'
