"""Service and action types: namespaces of the message classes they define."""

from __future__ import annotations

from typing import TYPE_CHECKING

from zros.cdr.model import ActionDef, ServiceDef

if TYPE_CHECKING:
    from zros.cdr.message import Message
    from zros.cdr.registry import TypeRegistry


class ServiceType:
    """A service type: ``.Request``, ``.Response`` and (Iron and later) ``.Event`` classes."""

    def __init__(self, registry: TypeRegistry, definition: ServiceDef) -> None:
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

    def __init__(self, registry: TypeRegistry, definition: ActionDef) -> None:
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
