"""A node's parameters served as the six ``rcl_interfaces`` services, changes on
``/parameter_events``.

The services answer on Zenoh's thread (so ROS tools reach the parameters of a node that does not
spin), except sets while the node has set callbacks: those run where the node spins, like
every user callback.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zros.cdr import Message

from zenoh import ZError

from zros.params.descriptor import Parameter
from zros.params.errors import ParameterError
from zros.params.store import ParameterStore
from zros.params.values import ParameterType, from_message, to_message
from zros.pubsub import Publisher
from zros.qos import PARAMETER_EVENTS
from zros.runtime.defaults import NodeLike
from zros.services import Service

_log = logging.getLogger('zros')

SERVICES = (
    'list_parameters',
    'get_parameters',
    'set_parameters',
    'set_parameters_atomically',
    'get_parameter_types',
    'describe_parameters',
)
SERVICE_TYPES = {
    'list_parameters': 'rcl_interfaces/srv/ListParameters',
    'get_parameters': 'rcl_interfaces/srv/GetParameters',
    'set_parameters': 'rcl_interfaces/srv/SetParameters',
    'set_parameters_atomically': 'rcl_interfaces/srv/SetParametersAtomically',
    'get_parameter_types': 'rcl_interfaces/srv/GetParameterTypes',
    'describe_parameters': 'rcl_interfaces/srv/DescribeParameters',
}
EVENTS_TOPIC = '/parameter_events'


class ParameterServer:
    """Serves one node's :class:`ParameterStore` and publishes its changes."""

    def __init__(self, node: NodeLike, store: ParameterStore) -> None:
        self.node = node
        self._context = node.context
        self.store = store
        registry = self._context.registry
        self._Value = registry.get_class('rcl_interfaces/msg/ParameterValue')
        self._Parameter = registry.get_class('rcl_interfaces/msg/Parameter')
        self._Result = registry.get_class('rcl_interfaces/msg/SetParametersResult')
        self._Event = registry.get_class('rcl_interfaces/msg/ParameterEvent')
        self._events = Publisher(EVENTS_TOPIC, self._Event, PARAMETER_EVENTS, node=node)
        handlers = {
            'list_parameters': self._list,
            'get_parameters': self._get,
            'set_parameters': self._set,
            'set_parameters_atomically': self._set_atomically,
            'get_parameter_types': self._types,
            'describe_parameters': self._describe,
        }
        no_callbacks = self._no_callbacks
        self.services: list[Service] = [
            Service(
                f'~/{name}',
                SERVICE_TYPES[name],
                handlers[name],
                node=node,
                inline=no_callbacks if name.startswith('set') else _always,
            )
            for name in SERVICES
        ]
        store.on_change = self._publish_event

    def _no_callbacks(self) -> bool:
        return not self.store.has_callbacks

    # --- conversions -----------------------------------------------------------------------------

    def _message(self, parameter: Parameter) -> Message:
        kind = parameter.type or ParameterType.NOT_SET
        return self._Parameter(
            name=parameter.name, value=to_message(parameter.value, kind, self._Value)
        )

    def _incoming(self, message: Message) -> Parameter | str:
        try:
            value, kind = from_message(message.value)
        except ParameterError as exc:
            return f"parameter '{message.name}': {exc}"
        return Parameter(message.name, value, kind)

    # --- the services --------------------------------------------------------------------------

    def _list(self, request: Message, response: Message) -> Message:
        names, prefixes = self.store.list_parameters(list(request.prefixes), request.depth)
        response.result.names = names
        response.result.prefixes = prefixes
        return response

    def _get(self, request: Message, response: Message) -> Message:
        parameters = [self.store.parameter(name) for name in request.names]
        response.values = [
            to_message(p.value, p.type or ParameterType.NOT_SET, self._Value) for p in parameters
        ]
        return response

    def _types(self, request: Message, response: Message) -> Message:
        response.types = [int(self.store.type_of(name)) for name in request.names]
        return response

    def _describe(self, request: Message, response: Message) -> Message:
        registry = self._context.registry
        response.descriptors = [
            self.store.describe(name).to_message(registry) for name in request.names
        ]
        return response

    def _set(self, request: Message, response: Message) -> Message:
        results = []
        for message in request.parameters:
            parameter = self._incoming(message)
            if isinstance(parameter, str):
                results.append(self._Result(successful=False, reason=parameter))
                continue
            outcome = self.store.set_atomically([parameter])
            results.append(self._Result(successful=outcome.successful, reason=outcome.reason))
        response.results = results
        return response

    def _set_atomically(self, request: Message, response: Message) -> Message:
        parameters = []
        for message in request.parameters:
            parameter = self._incoming(message)
            if isinstance(parameter, str):
                response.result = self._Result(successful=False, reason=parameter)
                return response
            parameters.append(parameter)
        outcome = self.store.set_atomically(parameters)
        response.result = self._Result(successful=outcome.successful, reason=outcome.reason)
        return response

    # --- events --------------------------------------------------------------------------------

    def _publish_event(
        self, new: list[Parameter], changed: list[Parameter], deleted: list[Parameter]
    ) -> None:
        if self._events.closed:
            return
        event = self._Event(
            stamp=self._context.clock.now().to_msg(),
            node=self._context.fully_qualified_name,
            new_parameters=[self._message(p) for p in new],
            changed_parameters=[self._message(p) for p in changed],
            deleted_parameters=[self._message(p) for p in deleted],
        )
        try:
            self._events.write(event)
        except ZError:  # a change must not fail because its event could not go out
            _log.debug('cannot publish a parameter event', exc_info=True)

    def close(self) -> None:
        """Stop serving the parameters and publishing their changes."""
        self.store.on_change = None
        for service in self.services:
            service.close()
        self._events.close()


def _always() -> bool:
    return True
