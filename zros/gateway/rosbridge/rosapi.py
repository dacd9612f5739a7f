"""The ``/rosapi/...`` services of rosbridge_suite's rosapi node, answered by the gateway itself.

Web clients (roslibjs ``ros.getTopics()``, ``ros.getNodes()``, ``ROSLIB.Param``...) call them
with ``call_service``; the gateway answers from the graph zros sees and zros's type registry,
with the request and response fields rosapi has for ROS 2 (no ``rosapi_msgs`` types are
needed: only the JSON shapes matter). They are not announced on the ROS graph.

Parameters are per node, named ``<node>:<param>`` (``/talker:use_sim_time``) as rosapi for
ROS 2 names them; values travel as JSON text. The globs filter topics, services and
parameters (the whole ``<node>:<param>`` name) as rosapi's ``*_glob`` parameters do.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from typing import TYPE_CHECKING

from zros.cdr.model import Kind, MessageDef
from zros.cdr.naming import attribute_name
from zros.cdr.render import render_bundle
from zros.errors import ZrosError
from zros.gateway.common.entities import PARAMETER_NODES, ClientCache
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.filters import NameFilter
from zros.gateway.common.json_types import text_field
from zros.gateway.common.views import endpoint_owner, offered_services, owners, parameter_nodes
from zros.gateway.rosbridge.conversion import short_name
from zros.keyexpr.kinds import EntityKind
from zros.pubsub.taps import is_hidden

if TYPE_CHECKING:
    from zros.gateway.common.json_types import JsonObject, OutObject
    from zros.node import Node
    from zros.params.client import ParameterClient

PREFIX = '/rosapi/'
#: how long a rosapi call waits for a graph just opened to learn what was there before it
GRAPH_FILLED_WITHIN = 2.0
#: the services that change the robot (refused by a read-only gateway)
WRITES = frozenset(('set_param', 'delete_param'))
#: seconds a node has to answer a parameter request
PARAMETER_TIMEOUT = 3.0
#: how rclpy spells the primitive types in ``get_fields_and_field_types`` (rosapi's typedefs)
_IDL_NAMES = {'float64': 'double', 'float32': 'float', 'bool': 'boolean', 'byte': 'octet',
              'char': 'uint8'}  # fmt: skip


class Rosapi:
    """Answers the rosapi services (see the module docstring)."""

    def __init__(
        self, node: Node, topics: NameFilter, services: NameFilter, params: NameFilter
    ) -> None:
        self._node = node
        self._topics = topics
        self._services = services
        self._params = params
        self._parameter_clients: ClientCache[ParameterClient] = ClientCache(PARAMETER_NODES)
        self._handlers: dict[str, Callable[[JsonObject], OutObject]] = {
            'topics': self._topics_and_types,
            'topics_for_type': self._topics_for_type,
            'topics_and_raw_types': self._raw_types,
            'topic_type': self._topic_type,
            'publishers': lambda a: {'publishers': self._endpoint_nodes(a, 'topic', 'PUB')},
            'subscribers': lambda a: {'subscribers': self._endpoint_nodes(a, 'topic', 'SUB')},
            'services': lambda a: {'services': sorted(self._service_types())},
            'services_for_type': self._services_for_type,
            'service_type': lambda a: {'type': self._service_types().get(_text(a, 'service'), '')},
            'service_providers': self._service_providers,
            'service_node': self._service_node,
            'nodes': lambda a: {'nodes': self._nodes()},
            'node_details': self._node_details,
            'action_servers': lambda a: {'action_servers': self._action_servers()},
            'message_details': lambda a: {'typedefs': self.typedefs(_text(a, 'type'))},
            'service_request_details': lambda a: {'typedefs': self._service_part(a, 'request')},
            'service_response_details': lambda a: {'typedefs': self._service_part(a, 'response')},
            'get_param': self._get_param,
            'set_param': self._set_param,
            'has_param': self._has_param,
            'delete_param': self._delete_param,
            'get_param_names': self._param_names,
            'get_time': self._time,
            'get_ros_version': lambda a: {'version': 2, 'distro': self._distro()},
        }

    def handles(self, service: str) -> bool:
        """Whether ``service`` (a resolved name) is one of rosapi's."""
        return service.startswith(PREFIX) and service[len(PREFIX) :] in self._handlers

    def writes(self, service: str) -> bool:
        """Whether ``service`` (one of rosapi's) changes the robot."""
        return service[len(PREFIX) :] in WRITES

    def call(self, service: str, args: JsonObject) -> OutObject:
        """The response values of a rosapi service (GatewayError says why there is none); on
        the gateway's call threads. A dashboard asks for the topics once, as it connects: the
        first answer waits for the graph's first fill (the graph opens with the first ask)."""
        self._node.graph.wait_filled(GRAPH_FILLED_WITHIN)
        return self._handlers[service[len(PREFIX) :]](args)

    def close(self) -> None:
        """Close the parameter clients."""
        self._parameter_clients.close()

    # --- topics and services -----------------------------------------------------------------

    def _topic_types(self) -> dict[str, str]:
        found = self._node.graph.topics(self._node.scheme.namespace)
        return {
            name: types[0]
            for name, types in found.items()
            if types and not is_hidden(name) and self._topics(name)
        }

    def _topics_and_types(self, args: JsonObject) -> OutObject:
        found = self._topic_types()
        return {'topics': list(found), 'types': list(found.values())}

    def _topics_for_type(self, args: JsonObject) -> OutObject:
        wanted = self._type_name(_text(args, 'type'))
        return {'topics': [n for n, t in self._topic_types().items() if t == wanted]}

    def _topic_type(self, args: JsonObject) -> OutObject:
        name = self._resolve(_text(args, 'topic'))
        return {'type': self._topic_types().get(name, '')}

    def _raw_types(self, args: JsonObject) -> OutObject:
        found = self._topic_types()
        texts = []
        for type_name in found.values():
            try:
                texts.append(render_bundle(self._node.registry, type_name))
            except ZrosError as exc:
                texts.append(f'# failed to get full definition text for {type_name}: {exc}')
        return {'topics': list(found), 'types': list(found.values()), 'typedefs_full_text': texts}

    def _service_types(self) -> dict[str, str]:
        found = offered_services(self._node)
        return {name: t for name, t in found.items() if self._services(name)}

    def _services_for_type(self, args: JsonObject) -> OutObject:
        wanted = self._type_name(_text(args, 'type'))
        return {'services': [n for n, t in self._service_types().items() if t == wanted]}

    def _endpoint_nodes(self, args: JsonObject, field: str, kind: str) -> list[str]:
        name = self._resolve(_text(args, field))
        if not self._topics(name):
            return []
        entity = EntityKind.PUBLISHER if kind == 'PUB' else EntityKind.SUBSCRIBER
        namespace = self._node.scheme.namespace
        found = [e for e in self._node.graph.endpoints((entity,)) if e.ros_name(namespace) == name]
        return owners(found, self._node.graph)

    def _servers(self, name: str) -> list[str]:
        namespace = self._node.scheme.namespace
        found = [
            e
            for e in self._node.graph.endpoints((EntityKind.SERVICE_SERVER,))
            if e.ros_name(namespace) == name
        ]
        return owners(found, self._node.graph) if self._services(name) else []

    def _service_providers(self, args: JsonObject) -> OutObject:
        return {'providers': self._servers(self._resolve(_text(args, 'service')))}

    def _service_node(self, args: JsonObject) -> OutObject:
        found = self._servers(self._resolve(_text(args, 'service')))
        return {'node': found[0] if found else ''}

    def _action_servers(self) -> list[str]:
        namespace = self._node.scheme.namespace
        return [n for n in self._node.graph.actions(namespace) if self._topics(n)]

    # --- nodes -------------------------------------------------------------------------------

    def _nodes(self) -> list[str]:
        services = offered_services(self._node, include_hidden=True)
        return sorted(set(self._node.graph.nodes()) | set(parameter_nodes(services)))

    def _node_details(self, args: JsonObject) -> OutObject:
        node_name = self._resolve(_text(args, 'node'))
        graph = self._node.graph
        namespace = self._node.scheme.namespace
        details: dict[str, list[str]] = {'subscribing': [], 'publishing': [], 'services': []}
        where = {
            EntityKind.SUBSCRIBER: 'subscribing',
            EntityKind.PUBLISHER: 'publishing',
            EntityKind.SERVICE_SERVER: 'services',
        }
        for endpoint in graph.endpoints(tuple(where)):
            name = endpoint.ros_name(namespace)
            mine = endpoint_owner(endpoint, graph) == node_name
            # ROS nodes behind a bridge are not named: their services carry their name
            if mine or (
                endpoint.kind is EntityKind.SERVICE_SERVER and name.startswith(node_name + '/')
            ):
                listed = details[where[endpoint.kind]]
                if name not in listed:
                    listed.append(name)
        return {key: sorted(names) for key, names in details.items()}

    # --- types -------------------------------------------------------------------------------

    def _type_name(self, text: str) -> str:
        """The full name of a type however it is spelled (``std_msgs/String``)."""
        try:
            found = self._node.registry.get_type(text)
        except ZrosError:
            return text
        for attribute in ('__msgtype__', '__srvtype__', '__actiontype__'):
            if hasattr(found, attribute):
                return str(getattr(found, attribute))
        return text

    def typedefs(self, type_name: str) -> list[OutObject]:
        """rosapi's ``TypeDef`` list of a message type and every type in it (GatewayError for
        a type zros does not know)."""
        try:
            definition = self._node.registry.message_definition(type_name)
        except ZrosError as exc:
            raise GatewayError(f'unknown type {type_name}: {exc}') from None
        return self._typedefs(definition)

    def _typedefs(self, root: MessageDef) -> list[OutObject]:
        found: list[OutObject] = []
        seen: set[str] = set()
        queue = [root]
        while queue:
            definition = queue.pop(0)
            if definition.name in seen:
                continue
            seen.add(definition.name)
            found.append(self._typedef(definition))
            for nested in definition.nested_types():
                queue.append(self._node.registry.message_definition(nested))
        return found

    def _typedef(self, definition: MessageDef) -> OutObject:
        defaults = self._node.registry.get_class(definition.name)()
        names, types, lengths, examples = [], [], [], []
        for field in definition.fields:
            kind = field.type
            names.append(field.name)
            if kind.is_nested:
                types.append(short_name(kind.base))
            else:
                base = _IDL_NAMES.get(kind.base, kind.base)
                types.append(f'{base}<{kind.string_bound}>' if kind.string_bound else base)
            length = {Kind.SCALAR: -1, Kind.ARRAY: kind.length}.get(kind.kind, 0)
            lengths.append(length)
            if length >= 0:
                examples.append('[]')
            elif kind.is_nested:
                examples.append('{}')
            else:
                examples.append(str(getattr(defaults, attribute_name(field.name))))
        return {
            'type': short_name(definition.name),
            'fieldnames': names,
            'fieldtypes': types,
            'fieldarraylen': lengths,
            'examples': examples,
            'constnames': [c.name for c in definition.constants],
            'constvalues': [str(c.value) for c in definition.constants],
        }

    def _service_part(self, args: JsonObject, part: str) -> list[OutObject]:
        text = _text(args, 'type')
        try:
            service = self._node.registry.get_service(text)
        except ZrosError as exc:
            raise GatewayError(f'unknown service type {text}: {exc}') from None
        cls = service.Request if part == 'request' else service.Response
        return self.typedefs(cls.__msgtype__)

    # --- parameters --------------------------------------------------------------------------

    def _parameter(self, args: JsonObject) -> tuple[str, str, str]:
        full = _text(args, 'name')
        node_name, _, name = full.partition(':')
        if not name or not node_name:
            raise GatewayError(
                f'malformed parameter name {full!r}; expecting <node_name>:<param_name>'
            )
        node_name = self._resolve(node_name)
        full = f'{node_name}:{name}'
        if not self._params(full):
            raise GatewayError(f'the parameter {full} is not allowed here (params glob)')
        return node_name, name, full

    def _client(self, node_name: str) -> ParameterClient:
        client: ParameterClient = self._parameter_clients.get(
            node_name, lambda: self._node.parameter_client(node_name, PARAMETER_TIMEOUT)
        )
        return client

    def _get_param(self, args: JsonObject) -> OutObject:
        default_text = args.get('default_value', args.get('default', ''))
        try:
            default = (
                json.loads(default_text) if isinstance(default_text, str) and default_text else ''
            )
        except (ValueError, TypeError):
            default = default_text
        try:
            node_name, name, full = self._parameter(args)
            value = self._client(node_name).get(name)
        except (GatewayError, ZrosError) as exc:
            return {'value': json.dumps(default), 'successful': False, 'reason': str(exc)}
        if value is None:
            reason = '' if default_text else f'{full} is not set'
            return {
                'value': json.dumps(default),
                'successful': bool(default_text),
                'reason': reason,
            }
        return {'value': json.dumps(value), 'successful': True, 'reason': ''}

    def _set_param(self, args: JsonObject) -> OutObject:
        try:
            node_name, name, _ = self._parameter(args)
            try:
                value = json.loads(_text(args, 'value'))
            except ValueError:
                raise GatewayError(
                    'the value argument to set_param must be a JSON-formatted string'
                ) from None
            (result,) = self._client(node_name).set_parameters({name: value})
        except (GatewayError, ZrosError) as exc:
            return {'successful': False, 'reason': str(exc)}
        return {'successful': bool(result), 'reason': result.reason}

    def _has_param(self, args: JsonObject) -> OutObject:
        try:
            node_name, name, _ = self._parameter(args)
            return {'exists': self._client(node_name).get(name) is not None}
        except (GatewayError, ZrosError):
            return {'exists': False}

    def _delete_param(self, args: JsonObject) -> OutObject:
        try:
            node_name, name, _ = self._parameter(args)
            (result,) = self._client(node_name).set_parameters({name: None})
        except (GatewayError, ZrosError) as exc:
            return {'successful': False, 'reason': str(exc)}
        return {'successful': bool(result), 'reason': result.reason}

    def _param_names(self, args: JsonObject) -> OutObject:
        own = self._node.fully_qualified_name
        names = []
        for node_name in parameter_nodes(offered_services(self._node, include_hidden=True)):
            if node_name == own:
                continue
            try:
                listed = self._client(node_name).list_parameters()
            except ZrosError:
                continue
            names += [f'{node_name}:{n}' for n in listed if self._params(f'{node_name}:{n}')]
        return {'names': names}

    # --- the rest ----------------------------------------------------------------------------

    def _time(self, args: JsonObject) -> OutObject:
        sec, nanosec = divmod(self._node.now().nanoseconds, 1_000_000_000)
        return {'time': {'sec': sec, 'nanosec': nanosec}}

    def _distro(self) -> str:
        return os.environ.get('ROS_DISTRO') or str(self._node.registry.distro)

    def _resolve(self, name: str) -> str:
        try:
            return self._node.resolve_name(name)
        except (ZrosError, ValueError) as exc:
            raise GatewayError(f'{name!r} is not a valid name: {exc}') from None


def _text(args: JsonObject, field: str) -> str:
    return text_field(args, field, '')
