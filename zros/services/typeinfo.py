"""Type definitions over the network: ``~/get_type_description``, as ROS 2 nodes serve it.

ROS 2 nodes (Iron and later; rclpy starts the service unless ``start_type_description_service``
is false) answer ``type_description_interfaces/srv/GetTypeDescription`` on
``<node>/get_type_description`` for the types their publishers, subscriptions and services use,
asked by name and RIHS01 hash. The answer holds the type's structure (fields, nested types,
default values) and, where the server has them, the definition files' text.

zros uses it both ways: :func:`learn_type` asks the nodes publishing a topic for a type zros
cannot resolve (the CLI does that before it reports an unknown type), and
:class:`TypeDescriptionService` answers for the types of a zros node's own entities: every node
starts one (:class:`NodeTypes`) when it first uses a type that is not standard, so the types it
registers at run time, finds in files or plays from a bag are described.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterable
from typing import TYPE_CHECKING

from zros.cdr.errors import UnknownTypeError
from zros.cdr.hashing import TypeDescription, message_text, type_description, type_hash
from zros.cdr.registry import registry_of
from zros.errors import ZrosError
from zros.runtime.defaults import NodeLike
from zros.services.client import Client
from zros.services.errors import ServiceError
from zros.services.server import Service

if TYPE_CHECKING:
    from zros.cdr.message import Message
    from zros.cdr.registry import TypeRegistry

SERVICE_TYPE = 'type_description_interfaces/srv/GetTypeDescription'
SERVICE_NAME = 'get_type_description'

#: longest type name looked up (ROS names are far shorter); longer ones are refused
MAX_NAME = 1024
#: characters of a request's name quoted back in a failure
SHOWN = 100

_log = logging.getLogger('zros.typeinfo')


class TypeDescriptionService:
    """Serve ``~/get_type_description`` for a node: the types of the classes given to ``add``,
    then whatever the node's registry resolves.

    Requests are answered on Zenoh's thread (no user code runs), so a node that never spins
    answers too. The reply carries the full description and, for types parsed from text, that
    text (comments included) as ``type_sources``.
    """

    def __init__(self, node: NodeLike, *, everything: bool = True) -> None:
        self.node = node
        #: also describe what the node's registry resolves, not only the types added
        self.everything = everything
        self._registry = node.context.registry
        self._registries: dict[str, TypeRegistry] = {}
        self._service: Service = Service(
            f'~/{SERVICE_NAME}', SERVICE_TYPE, self._answer, node=node, inline=lambda: True
        )

    def add(self, cls: type[Message]) -> None:
        """Describe ``cls``'s type from the registry that built it (a bag's, say)."""
        self.add_type(cls.__msgtype__, registry_of(cls))

    def add_type(self, type_name: str, registry: TypeRegistry) -> None:
        """Describe ``type_name`` from ``registry``."""
        self._registries[type_name] = registry

    def _registry_for(self, type_name: str) -> TypeRegistry | None:
        found = self._registries.get(type_name)
        if found is not None or not self.everything:
            return found
        registry = self._registry
        try:
            registry.definition(type_name)
        except (UnknownTypeError, ZrosError, ValueError):
            return None
        return registry

    def _answer(self, request: Message) -> Message:
        try:
            return self._describe(request)
        except Exception as exc:  # a request the checks above missed: answered, never raised
            _log.debug('describing %.200r failed', request.type_name, exc_info=True)
            return self._service.Response(
                successful=False, failure_reason=f'{_shown(request.type_name)} failed: {exc}'
            )

    def _describe(self, request: Message) -> Message:
        response = self._service.Response
        name = request.type_name
        registry = self._registry_for(name) if len(name) <= MAX_NAME else None
        if registry is None:
            reason = f'{_shown(name)} is not a type of this node'
            return response(successful=False, failure_reason=reason)
        ours = type_hash(registry, name)
        if request.type_hash and request.type_hash != ours:
            return response(
                successful=False,
                failure_reason=f'{name} has the hash {ours} here, not {_shown(request.type_hash)}',
            )
        description = type_description(registry, name)
        sources = []
        if request.include_type_sources:
            sources = list(_sources(registry, description))
        return response.from_dict(
            {
                'successful': True,
                'type_description': description,
                'type_sources': sources,
            }
        )

    def close(self) -> None:
        """Stop serving."""
        self._service.close()


class NodeTypes:
    """A node's ``~/get_type_description``, started when one of its entities first uses a type
    that is not standard (one found in files or registered at run time): nodes with standard
    types only add nothing to the graph. Once started it describes every type the node's
    entities used (standard ones too, as ROS 2 nodes do), and nothing else.

    Set as the node context's ``type_used``, so it runs while an entity is being made.
    """

    def __init__(self, node: NodeLike) -> None:
        self.node = node
        self._used: dict[str, TypeRegistry] = {}
        self._lock = threading.RLock()
        self.service: TypeDescriptionService | None = None

    def __call__(self, type_name: str, registry: TypeRegistry) -> None:
        if type_name == SERVICE_TYPE or type_name in self._used:
            return
        try:
            if registry.find(type_name) is None:
                return  # a tap on a type nobody here knows
        except (ZrosError, ValueError):
            return
        with self._lock:
            names = [type_name]
            parent = registry.parent(type_name)  # an action's parts name the action
            if parent is not None:
                names.append(parent)
            for name in names:
                self._used[name] = registry
                if self.service is not None:
                    self.service.add_type(name, registry)
            if self.service is None and not registry.standard(type_name):
                self.service = TypeDescriptionService(self.node, everything=False)
                for name, used in self._used.items():
                    self.service.add_type(name, used)


def _shown(text: str) -> str:
    """``text`` cut short for a reply (a request may carry a huge name)."""
    return repr(text) if len(text) <= SHOWN else repr(text[:SHOWN]) + f'... ({len(text)} chars)'


def _sources(registry: TypeRegistry, description: TypeDescription) -> Iterable[dict[str, str]]:
    """TypeSource entries (``msg`` text with comments) for the types parsed from text."""
    individuals = [description['type_description'], *description['referenced_type_descriptions']]
    for individual in individuals:
        name = individual['type_name']
        try:
            definition = registry.message_definition(name)
        except UnknownTypeError:
            continue
        if definition.source and name.split('/')[1] == 'msg':
            yield {'type_name': name, 'encoding': 'msg', 'raw_file_contents': definition.source}


def register_description(registry: TypeRegistry, response: Message, origin: str) -> None:
    """Register the definitions of a successful answer: the sources' text where given (it has
    the constants and comments), else text rebuilt from the description."""
    texts = {
        source.type_name: source.raw_file_contents
        for source in response.type_sources
        if source.encoding == 'msg' and source.raw_file_contents
    }
    description = response.type_description.to_dict()
    individuals = [description['type_description'], *description['referenced_type_descriptions']]
    main = individuals[0]['type_name']
    for individual in reversed(individuals):  # dependencies first
        name = individual['type_name']
        if name != main and registry.find(name) is not None:
            continue  # a known dependency keeps its definition
        text = texts.get(name) or message_text(individual)
        try:
            registry.register_text(name, text, origin)
        except ZrosError:  # a default value our parser reads otherwise: keep the structure
            registry.register_text(name, message_text(individual, with_defaults=False), origin)


def learn_type(
    node: NodeLike,
    type_name: str,
    owners: Iterable[tuple[str, str | None]],
    timeout: float = 5.0,
) -> str | None:
    """Ask the nodes in ``owners`` (``(node name, type hash or None)``, e.g. a topic's
    publishers) for ``type_name`` and register the answer in the node's registry.

    Returns the node that described it, or None when none could (no such service, a failure).
    """
    registry = node.context.registry
    for owner, owner_hash in owners:
        client = Client(
            f'{owner.rstrip("/")}/{SERVICE_NAME}', SERVICE_TYPE, node=node, timeout=timeout
        )
        try:
            if not client.wait_for_service(timeout):
                continue
            try:
                response = client.call(
                    type_name=type_name, type_hash=owner_hash or '', include_type_sources=True
                )
            except ServiceError as exc:
                _log.debug('%s did not describe %s: %s', owner, type_name, exc)
                continue
        finally:
            client.close()
        if not response.successful:
            _log.debug('%s did not describe %s: %s', owner, type_name, response.failure_reason)
            continue
        register_description(registry, response, f'{owner}/{SERVICE_NAME}')
        return owner
    return None


__all__ = [
    'SERVICE_NAME',
    'SERVICE_TYPE',
    'NodeTypes',
    'TypeDescriptionService',
    'learn_type',
    'register_description',
]
