"""What a session's graph hears of one wire scheme (:class:`TokenView`), and what it shows:
:class:`Endpoint` and :class:`BridgeInfo`.

Each scheme's view follows its own liveliness tokens (the selectors it names) and answers as
endpoints and node names; the graph (``zros.graph``) holds one view per scheme of
:data:`zros.wire.SCHEMES` and knows no scheme itself.
"""

from __future__ import annotations

import abc
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, TypeVar

from zros.keyexpr.kinds import EntityKind
from zros.qos import QoS

if TYPE_CHECKING:
    from zenoh import SampleKind, Session

    from zros.cdr import JsonValue

_T = TypeVar('_T')
#: the graph's logger (what the views ignore, and why)
graph_log = logging.getLogger('zros.graph')


class TokenSample(Protocol):
    """What a view reads of a liveliness sample: a Zenoh ``Sample``, or a :class:`LocalToken`."""

    @property
    def key_expr(self) -> object: ...  # read as str(key_expr)

    @property
    def kind(self) -> SampleKind: ...


@dataclass(frozen=True)
class LocalToken:
    """A token this session declared (or undeclared), handed to its own graph at once."""

    key_expr: str
    kind: SampleKind


TokenHandler = Callable[[TokenSample], None]


def keep_token(table: dict[str, _T], key: str, token: _T, alive: bool) -> None:
    """Add ``token`` under ``key`` while it is alive; remove it once it is gone."""
    if alive:
        table[key] = token
    else:
        table.pop(key, None)


@dataclass(frozen=True)
class Endpoint:
    """One publisher, subscriber, service or action endpoint on the network."""

    kind: EntityKind
    zid: str  #: the Zenoh session announcing it (a bridge's, or a zros process's)
    key: str  #: its Zenoh key
    type_name: str
    qos: QoS | None  #: publishers and subscribers
    node: str | None  #: the node owning it, when known (zros nodes, rmw_zenoh nodes)
    wire: str = 'bridge'  #: the scheme that announced it: 'bridge' or 'rmw_zenoh'
    name: str | None = None  #: rmw_zenoh: the ROS name as announced
    gid: bytes | None = None  #: rmw_zenoh: the entity's GID (what ``ros2 topic info -v`` shows)
    type_hash: str | None = None  #: its type's RIHS01 hash, when announced
    #: the ROS name of ``key`` seen through a bridge namespace (where ``name`` is not given)
    naming: Callable[[str, str], str] | None = field(default=None, compare=False, repr=False)

    def ros_name(self, namespace: str = '/') -> str:
        """Its ROS name (through a bridge with ``namespace``, for bridged endpoints)."""
        if self.name is not None:
            return self.name
        return self.naming(self.key, namespace) if self.naming is not None else self.key

    @property
    def is_bridged(self) -> bool:
        """Whether a bridge announces it (a ROS entity behind that bridge)."""
        return self.node is None


@dataclass(frozen=True)
class BridgeInfo:
    """A zenoh-bridge-ros2dds on the network."""

    zid: str
    version: str | None = None  #: e.g. ``1.10.0`` (None until its admin space answered)
    namespace: str | None = None
    nodename: str | None = None

    @classmethod
    def from_admin(cls, zid: str, answers: dict[str, JsonValue]) -> BridgeInfo:
        """A bridge from the JSON its admin space gave (``version`` and ``config``)."""
        config = answers.get('config')
        settings: dict[str, JsonValue] = config if isinstance(config, dict) else {}
        version = answers.get('version')
        namespace, nodename = settings.get('namespace'), settings.get('nodename')
        return cls(
            zid,
            str(version).lstrip('v') if version is not None else None,
            namespace if isinstance(namespace, str) else None,
            nodename if isinstance(nodename, str) else None,
        )

    @property
    def version_tuple(self) -> tuple[int, ...] | None:
        """The version as numbers, e.g. ``(1, 10, 0)``; None if unknown."""
        if not self.version:
            return None
        digits = self.version.lstrip('v').split('-')[0].split('.')
        try:
            return tuple(int(part) for part in digits)
        except ValueError:
            return None

    @property
    def node_name(self) -> str:
        """The one ROS node the bridge shows: ``<namespace>/<nodename>``."""
        namespace = self.namespace or '/'
        return namespace.rstrip('/') + '/' + (self.nodename or 'zenoh_bridge_ros2dds')


class TokenView(abc.ABC):
    """What one session hears of one scheme's tokens; ``changed()`` after each change (on
    Zenoh's threads)."""

    def __init__(self, session: Session, changed: Callable[[], None]) -> None:
        self.session = session
        self.changed = changed
        self.lock = threading.Lock()
        self.closed = False

    @abc.abstractmethod
    def selectors(self) -> list[tuple[str, TokenHandler]]:
        """The liveliness selectors of the scheme's tokens, each with what handles a sample."""

    @abc.abstractmethod
    def endpoints(self) -> list[Endpoint]:
        """Every endpoint announced."""

    @abc.abstractmethod
    def nodes(self) -> set[str]:
        """Fully qualified names of the nodes announced (or shown, as a bridge's)."""

    def node_instances(self) -> list[str]:
        """The fully qualified name of each node announced, once per node: two nodes that
        share a name are there twice."""
        return sorted(self.nodes())

    @abc.abstractmethod
    def present(self) -> bool:
        """Whether anything of the scheme is on the network."""

    def bridges(self) -> list[BridgeInfo]:
        """The bridges present (none but for the scheme of bridges)."""
        return []

    def settled(self) -> bool:
        """Whether what the view asks beyond tokens (a bridge's version) has answered."""
        return True

    def close(self) -> None:
        """Stop answering late news."""
        self.closed = True
