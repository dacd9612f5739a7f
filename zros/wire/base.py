"""The one interface of a wire scheme: :class:`Wire` (one per node) and :class:`WireEntity`
(one per entity).

Everything that differs between zenoh-bridge-ros2dds and rmw_zenoh is answered here: keys,
liveliness tokens, GIDs, attachments on what an entity sends, which samples a subscriber
accepts, the options of transient-local publishers and subscribers, how a server admits and
answers queries, what a client sends with a request and how it checks a reply. The bases hold
the plain behaviour (no attachments); a scheme overrides what it adds. Adding a scheme is one
module with a :class:`Wire` subclass, listed in :data:`zros.wire.SCHEMES`.
"""

from __future__ import annotations

import abc
import warnings
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, ClassVar, Protocol, TypedDict

from zenoh import ConsolidationMode, QueryTarget, Sample, ext

from zros.keyexpr.kinds import EntityKind
from zros.qos import QoS
from zros.transport.config import SessionDefaults
from zros.wire.requests import Requests
from zros.wire.schemes import WireOption
from zros.wire.tokens import TokenView

if TYPE_CHECKING:
    from zros.cdr import TypeRegistry
    from zros.transport import Transport

SampleCallback = Callable[[Sample], None]


class PublisherOptions(TypedDict, total=False):
    """Extra options of a zenoh-ext advanced publisher."""

    sample_miss_detection: ext.MissDetectionConfig


class SubscriberOptions(TypedDict, total=False):
    """Extra options of a zenoh-ext advanced subscriber."""

    subscriber_detection: bool
    recovery: ext.RecoveryConfig


class QueryOptions(TypedDict, total=False):
    """Extra options of ``session.get`` for a request."""

    attachment: bytes | None
    target: QueryTarget
    consolidation: ConsolidationMode


class QueryableOptions(TypedDict, total=False):
    """Extra options of a server's queryable."""

    complete: bool


BatchCallback = Callable[[list[Sample]], None]


class KeyScheme(Protocol):
    """The pure key functions of a scheme (``zros.keyexpr``) that callers above use."""

    @property
    def namespace(self) -> str:
        """The bridge namespace names are seen through (``/`` where there is none)."""

    def key(self, ros_name: str) -> str:
        """How the graph identifies a topic, service or action of this scheme."""


class Put(Protocol):
    """A Zenoh publisher's ``put``: a payload and, under rmw_zenoh, its attachment."""

    def __call__(self, payload: bytes | bytearray, *, attachment: bytes | None = ...) -> None:
        """Publish ``payload``."""


class WireEntity:
    """Where one entity lives on the wire (``key``, ``tokens``, ``gid``) and what the wire
    asks of it. This base is the plain form: nothing attached, every sample accepted."""

    #: why :meth:`admitting` turns a sample away (for the drop counters)
    rejection = ''

    def __init__(self, key: str, tokens: tuple[str, ...] = (), gid: bytes | None = None) -> None:
        self.key = key  #: the Zenoh key to declare on
        self.tokens = tokens  #: liveliness tokens announcing it, declared in order
        self.gid = gid  #: its GID, where the scheme gives entities one

    def sender(self, put: Put) -> Callable[[bytes | bytearray], None]:
        """The function that publishes one payload through ``put`` (a Zenoh publisher's)."""
        return put

    def admitting(self, callback: BatchCallback, rejected: SampleCallback) -> BatchCallback:
        """A subscriber's batch callback: ``callback(samples)`` with the samples this wire
        accepts (never an empty list), ``rejected(sample)`` for each of the others. The plain
        form accepts every sample."""
        return callback

    def publisher_options(self, qos: QoS) -> PublisherOptions:
        """Extra options of a transient-local (zenoh-ext advanced) publisher."""
        return {}

    def subscriber_options(self, qos: QoS) -> SubscriberOptions:
        """Extra options of a transient-local (zenoh-ext advanced) subscriber."""
        return {}

    def requests(self, name: str, error_prefix: str) -> Requests:
        """How a server of this entity admits and answers queries."""
        return Requests(name, error_prefix)

    def request_attachment(self) -> bytes | None:
        """What the next request of a client carries (None: nothing)."""
        return None

    def query_options(self, attachment: bytes | None) -> QueryOptions:
        """The options of ``session.get`` for a request carrying ``attachment``."""
        return {}

    def reply_problem(self, reply: Sample, attachment: bytes | None) -> str | None:
        """Why a reply does not answer the request sent with ``attachment``; None if it does."""
        return None

    def __repr__(self) -> str:
        return f'<{type(self).__name__} {self.key}>'


class Wire(abc.ABC):
    """One node's side of a wire scheme: its keys, its node token, its entities' places."""

    #: the scheme's name, as ``wire=`` and ``ZROS_WIRE`` give it
    name: ClassVar[str]
    #: the pure key and token functions of the scheme
    scheme: KeyScheme
    #: what a session's graph hears of the scheme's tokens
    token_view: ClassVar[type[TokenView]]
    #: what two endpoints of one topic with different types do on this scheme (for the warning)
    type_conflict: ClassVar[str]
    #: what the scheme's sessions do where their settings say nothing (Zenoh's mode, router,
    #: listening endpoint, the variables naming a file and overrides)
    session: ClassVar[SessionDefaults] = SessionDefaults()

    def __init__(
        self,
        transport: Transport,
        namespace: str,
        node_name: str,
        registry: TypeRegistry,
        settings: Mapping[str, WireOption],
    ) -> None:
        """The wire of the node ``namespace``/``node_name``; each scheme reads its own
        ``settings`` (``zros.wire.open_wire`` checked it takes each one given)."""
        self.transport = transport
        self.node_namespace = namespace
        self.node_name = node_name

    @property
    def node_fqn(self) -> str:
        """``/namespace/name`` of the node."""
        return self.node_namespace.rstrip('/') + '/' + self.node_name

    @property
    def namespace(self) -> str:
        """The bridge namespace names are seen through (``/`` where there is none)."""
        return self.scheme.namespace

    @property
    @abc.abstractmethod
    def node_token(self) -> str:
        """The liveliness key announcing the node."""

    def key(self, ros_name: str) -> str:
        """How the graph identifies a topic, service or action of this scheme."""
        return self.scheme.key(ros_name)

    @abc.abstractmethod
    def entity(
        self,
        kind: EntityKind,
        ros_name: str,
        type_name: str,
        registry: TypeRegistry,
        *,
        qos: QoS | None = None,
        announce: bool = True,
        owned: bool = True,
    ) -> WireEntity:
        """The place of one entity of the node; ``announce`` False gives it no tokens,
        ``owned`` False announces it as no node's (a bridge then shows it on its own)."""

    @abc.abstractmethod
    def unannounced(self, key: str) -> WireEntity:
        """An entity on a key given as is (a type the node cannot make keys for), no tokens."""

    @abc.abstractmethod
    def action_tokens(
        self, kind: EntityKind, ros_name: str, type_name: str, registry: TypeRegistry
    ) -> tuple[str, ...]:
        """The tokens announcing an action server or client as a whole (none where the
        scheme announces its parts instead)."""

    @abc.abstractmethod
    def announces_action_parts(self) -> bool:
        """Whether an action's services and topics are announced one by one."""

    @staticmethod
    @abc.abstractmethod
    def any_type_key(key: str) -> str:
        """The key expression matching every type on a key the graph shows."""

    def queryable_options(self) -> QueryableOptions:
        """The options of a server's queryable: complete, so clients that ask only complete
        queryables find it."""
        return {'complete': True}

    def __str__(self) -> str:
        return self.name

    def __eq__(self, other: object) -> bool:
        if isinstance(other, str):  # node.wire was the scheme's name (a str) before
            warnings.warn(
                "node.wire is the node's Wire: compare node.wire.name with a scheme's name",
                DeprecationWarning,
                stacklevel=2,
            )
            return self.name == other
        return self is other

    def __hash__(self) -> int:
        return object.__hash__(self)

    def __repr__(self) -> str:
        return f'<{type(self).__name__} {self.scheme!r}>'
