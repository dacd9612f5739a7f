"""The one base of everything a node declares on Zenoh, and the one way to subscribe raw.

An :class:`Entity` takes its place on the node's wire (key, liveliness tokens, GID), declares
its Zenoh objects through the helpers here, announces itself, and is closed once: tokens
retired (newest first), Zenoh objects undeclared, parts closed, then what the kind adds.
:meth:`Entity._subscribe` is the single raw subscription of zros: the wire's admission rule
(rmw_zenoh drops samples without a valid attachment), and for transient local a zenoh-ext
advanced subscriber with the wire's options; the callback runs on the subscription's delivery
thread (``zros.transport.delivery``), or Zenoh's for transient local.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol, TypeVar

from zenoh import Query, Sample, ZError, ext

from zros.cdr import Message
from zros.keyexpr.kinds import EntityKind
from zros.qos import QoS
from zros.runtime.context import NodeContext
from zros.runtime.defaults import NodeLike, default_node
from zros.transport import delivery

if TYPE_CHECKING:
    from zros.cdr import TypeRegistry
    from zros.wire import WireEntity

_log = logging.getLogger('zros')


class Undeclarable(Protocol):
    """A Zenoh object an entity declared: subscriber, queryable, publisher, querier..."""

    def undeclare(self) -> None:
        """Withdraw it from the session."""


D = TypeVar('D', bound=Undeclarable)


def message_class(registry: TypeRegistry, msg_type: str | type[Message]) -> type[Message]:
    """The message class of a type name (from ``registry``) or a message class."""
    if isinstance(msg_type, type):
        if not issubclass(msg_type, Message):
            raise TypeError(f'{msg_type!r} is not a zros message class')
        return msg_type
    return registry.get_class(msg_type)


def _each(callback: Callable[[Sample], None]) -> Callable[[list[Sample]], None]:
    """A batch callback calling ``callback`` per sample (one that raises spoils no other)."""

    def each(samples: list[Sample]) -> None:
        for sample in samples:
            try:
                callback(sample)
            except Exception:  # a raw tap's callback: logged, the batch goes on
                _log.exception('the callback %r of a subscription raised', callback)

    return each


#: what an entity's name is, by its kind (for name resolution and its errors)
_NAME_KINDS = {
    EntityKind.PUBLISHER: 'topic name',
    EntityKind.SUBSCRIBER: 'topic name',
    EntityKind.SERVICE_SERVER: 'service name',
    EntityKind.SERVICE_CLIENT: 'service name',
    EntityKind.ACTION_SERVER: 'action name',
    EntityKind.ACTION_CLIENT: 'action name',
}

#: seconds close() waits for a call still running in another thread before it says so
WAIT_WARNING = 5.0


class Entity:
    """A publisher, subscriber, service, client, action part, tap... of a node (``node``
    None: the default node of ``zros.init``)."""

    def __init__(self, node: NodeLike | None) -> None:
        owner = node if node is not None else default_node()
        self.node: NodeLike = owner  #: the node it belongs to
        self.context: NodeContext = owner.context
        self.context.check_open()
        self.key = ''  #: its Zenoh key expression, once it has a name
        self.gid: bytes | None = None  #: its GID, on wires that give entities one
        self._tokens: tuple[str, ...] = ()
        self._declared: list[Undeclarable] = []
        self._parts: list[Entity] = []
        self._closed = False
        #: held around calls into its Zenoh objects from other threads, and by close() while it
        #: undeclares them (a call that does not hold it is waited for: see _undeclare_all)
        self._in_use = threading.Lock()

    # --- while it is made ----------------------------------------------------------------

    def _place(
        self,
        kind: EntityKind,
        name: str,
        type_name: str,
        registry: TypeRegistry,
        *,
        qos: QoS | None = None,
        announce: bool = True,
        owned: bool = True,
        own: bool = False,
    ) -> WireEntity:
        """A place on the node's wire for ``name`` (resolved: see :meth:`_resolve`); the tokens
        are declared by :meth:`_announce`. With ``own`` it is the entity's own place (a
        publisher's, a service's..., not a part's): its key and GID become the entity's."""
        wire = self.context.wire.entity(
            kind, name, type_name, registry, qos=qos, announce=announce, owned=owned
        )
        self._tokens += wire.tokens
        if owned and self.context.type_used is not None:
            self.context.type_used(type_name, registry)
        if own:
            self.key = wire.key
            self.gid = wire.gid
        return wire

    def _resolve(self, kind: EntityKind, name: str) -> str:
        """``name`` fully qualified and remapped, as the name of a ``kind`` entity (a topic,
        service or action name: the errors say which)."""
        return self.context.resolve_name(name, _NAME_KINDS[kind])

    def _add_tokens(self, tokens: tuple[str, ...]) -> None:
        """More tokens announcing it (an action as a whole)."""
        self._tokens += tokens

    def _keep(self, declared: D) -> D:
        """Undeclare ``declared`` (a Zenoh subscriber, queryable...) when it closes."""
        self._declared.append(declared)
        return declared

    def _part(self, part: Entity) -> None:
        """Close ``part`` (an entity it is made of) with it."""
        self._parts.append(part)

    def _subscribe(
        self,
        wire: WireEntity,
        qos: QoS,
        callback: Callable[[Sample], None] | None = None,
        *,
        batches: Callable[[list[Sample]], None] | None = None,
        rejected: Callable[[Sample], None] | None = None,
        late_publishers: bool = True,
    ) -> Undeclarable:
        """Subscribe to ``wire.key``: ``callback(sample)`` for each sample the wire accepts
        (or ``batches(samples)`` for several at once), ``rejected(sample)`` for the others
        (default: a debug line), on a thread that is not the spinning one (zros's delivery
        thread, or Zenoh's for transient local, which fetches the publishers' caches, of
        ``late_publishers`` too)."""
        if batches is None:
            if callback is None:
                raise TypeError('_subscribe needs a callback or batches')
            batches = _each(callback)
        refuse = rejected or self._rejected(wire.rejection)
        on_samples = wire.admitting(batches, refuse)
        session = self.context.transport.session
        subscriber: Undeclarable
        if qos.transient_local:
            history = ext.HistoryConfig(detect_late_publishers=late_publishers,
                                        max_samples=qos.depth)  # fmt: skip
            subscriber = ext.declare_advanced_subscriber(
                session, wire.key, lambda sample: on_samples([sample]), history=history,
                **wire.subscriber_options(qos),
            )  # fmt: skip
        else:
            plain = session.declare_subscriber(wire.key, delivery.channel())
            delivery.deliver(plain, on_samples, wire.key)
            subscriber = plain
        return self._keep(subscriber)

    def _rejected(self, reason: str) -> Callable[[Sample], None]:
        def rejected(sample: Sample) -> None:
            _log.debug('dropped a sample on %s: %s', sample.key_expr, reason)

        return rejected

    def _serve(self, wire: WireEntity, callback: Callable[[Query], None]) -> Undeclarable:
        """A queryable on ``wire.key`` calling ``callback(query)`` on Zenoh's thread."""
        session = self.context.transport.session
        options = self.context.wire.queryable_options()
        queryable: Undeclarable = session.declare_queryable(wire.key, callback, **options)
        return self._keep(queryable)

    def _announce(self) -> None:
        """Declare its tokens (after its Zenoh objects) and have the node close it."""
        transport = self.context.transport
        for token in self._tokens:
            transport.declare_token(token)
        self.context.add(self)

    # --- lifetime ------------------------------------------------------------------------

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._closed

    def close(self) -> None:
        """Withdraw it from the network; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        transport = self.context.transport
        for token in reversed(self._tokens):
            transport.release_token(token)
        if not transport.closed:
            with self._in_use:
                self._undeclare_all()
        for part in self._parts:
            part.close()
        self._on_close()
        self.context.remove(self)

    def _undeclare_all(self) -> None:
        for declared in self._declared:
            _undeclare(declared, self)

    def _on_close(self) -> None:
        """What a kind of entity does once withdrawn (wake its waiters, fail its requests)."""


def _undeclare(declared: Undeclarable, owner: object) -> None:
    """Undeclare one Zenoh object. zenoh-python refuses while another thread is inside one of
    its calls ('Already borrowed'): that call (a put, which takes no lock) is waited for."""
    delay = 0.0001
    warn_at = time.monotonic() + WAIT_WARNING
    while True:
        try:
            declared.undeclare()
            return
        except ZError:  # the session closes under it
            _log.debug('undeclaring on %s failed', owner, exc_info=True)
            return
        except RuntimeError as exc:
            if 'borrowed' not in str(exc):
                raise
        if warn_at and time.monotonic() > warn_at:  # a put blocked by a congested network
            _log.warning('closing %s waits for a call another thread is still in', owner)
            warn_at = 0.0
        time.sleep(delay)
        delay = min(delay * 2, 0.01)
