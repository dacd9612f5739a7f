"""What entities get from their node: :class:`NodeContext`.

A node builds one context and hands it to everything it owns; entities never reach into the
node itself. The context holds the session, the wire, the type registry, the executor and the
clock, resolves names, and keeps the list of open entities, which it closes with the node.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from zros.keyexpr.names import Remapping, expand
from zros.runtime.clock import Clock
from zros.runtime.executor import Executor
from zros.runtime.signal import interrupted

if TYPE_CHECKING:
    from zros.cdr import TypeRegistry
    from zros.transport import Transport
    from zros.wire import Wire

_log = logging.getLogger('zros')


class Closable(Protocol):
    """An entity the context closes with its node."""

    def close(self) -> None:
        """Withdraw it from the network (idempotent)."""


class NodeContext:
    """One node's session, wire, registry, executor and clock, its names, and its entities."""

    def __init__(
        self,
        name: str,
        namespace: str,
        *,
        remapping: Remapping,
        transport: Transport,
        wire: Wire,
        registry: TypeRegistry,
        clock: Clock,
        immediate_callbacks: bool = False,
    ) -> None:
        self.name = name
        self.namespace = namespace
        self.remapping = remapping
        self.transport = transport
        self.wire = wire
        self.registry = registry
        self.clock = clock
        self.executor = Executor(self.fully_qualified_name, immediate=immediate_callbacks)
        self._entities: list[Closable] = []
        self._lock = threading.Lock()
        self._closed = False
        #: told ``(type name, registry)`` by each entity the node places (the node's
        #: ``~/get_type_description`` learns its types from it); None: nobody listens
        self.type_used: Callable[[str, TypeRegistry], None] | None = None

    @property
    def fully_qualified_name(self) -> str:
        """``/namespace/name`` of the node."""
        return self.namespace.rstrip('/') + '/' + self.name

    def resolve_name(self, name: str, kind: str = 'topic name') -> str:
        """The fully qualified form of a topic or service name, remappings applied."""
        full = expand(name, self.name, self.namespace, kind)
        return self.remapping.apply(full, self.name, self.namespace)

    @property
    def closed(self) -> bool:
        """Whether the node was destroyed."""
        return self._closed

    def ok(self) -> bool:
        """True until the node is destroyed or the process got Ctrl-C."""
        return not (self._closed or interrupted())

    def check_open(self) -> None:
        """RuntimeError once the node was destroyed."""
        if self._closed:
            raise RuntimeError(f'node {self.fully_qualified_name} was destroyed')

    def add(self, entity: Closable) -> None:
        """Close ``entity`` with the node (RuntimeError once the node was destroyed)."""
        with self._lock:
            self.check_open()
            self._entities.append(entity)

    def remove(self, entity: Closable) -> None:
        """``entity`` closed on its own: forget it."""
        with self._lock:
            if entity in self._entities:
                self._entities.remove(entity)

    @property
    def entities(self) -> list[Closable]:
        """The entities open now, oldest first."""
        with self._lock:
            return list(self._entities)

    def close(self) -> None:
        """Close every entity (newest first) and stop the executor; safe to call twice."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            entities, self._entities = list(reversed(self._entities)), []
        self.executor.stopped = True
        for entity in entities:
            entity.close()
        self.executor.stop()
