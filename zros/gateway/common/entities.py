"""The gateway's own node and what it makes on its clients' behalf: the service and parameter
clients (:class:`ClientCache`, closed together) and the QoS of the publishers clients ask for
(:func:`publisher_qos`), and starting a gateway on its node (:func:`start_gateway`)."""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable, Hashable, Iterable
from typing import TYPE_CHECKING, Generic, Protocol, TypeVar

from zros.node import Node
from zros.pubsub.taps import matched_qos
from zros.qos import Durability, QoS

if TYPE_CHECKING:
    from zros.node.settings import NodeKeywords


#: the parameter clients a gateway keeps (one per node asked; clients name nodes freely)
PARAMETER_NODES = 1000


class Closable(Protocol):
    """What :class:`ClientCache` holds: anything with ``close()``."""

    def close(self) -> None: ...


C = TypeVar('C', bound=Closable)


class ClientCache(Generic[C]):
    """The service or parameter clients a gateway made, one per key, made on first use and
    closed together (thread-safe). With a ``capacity``, the least recently used client is
    closed to make room: for keys a client may name freely (the nodes it asks parameters of),
    which would otherwise each leave a client behind."""

    def __init__(self, capacity: int | None = None) -> None:
        self._lock = threading.Lock()
        self._clients: collections.OrderedDict[Hashable, C] = collections.OrderedDict()
        self._capacity = capacity

    def get(self, key: Hashable, make: Callable[[], C]) -> C:
        """The client of ``key``, made by ``make()`` the first time."""
        evicted = None
        with self._lock:
            client = self._clients.get(key)
            if client is None:
                client = self._clients[key] = make()
                if self._capacity is not None and len(self._clients) > self._capacity:
                    _, evicted = self._clients.popitem(last=False)
            else:
                self._clients.move_to_end(key)
        if evicted is not None:
            evicted.close()
        return client

    def keep(self, key: Hashable, client: C) -> bool:
        """Keep ``client`` as the client of ``key`` unless there is one already (then False:
        the caller still owns ``client``)."""
        with self._lock:
            if key in self._clients:
                return False
            self._clients[key] = client
        return True

    def discard(self, key: Hashable) -> None:
        """Close and forget the client of ``key`` (if any)."""
        with self._lock:
            client = self._clients.pop(key, None)
        if client is not None:
            client.close()

    def close(self) -> None:
        """Close every client."""
        with self._lock:
            clients = list(self._clients.values())
            self._clients.clear()
        for client in clients:
            client.close()


def gateway_node(name: str, settings: NodeKeywords) -> Node:
    """A node of its own for a gateway, from the connection ``settings`` of :class:`zros.Node`
    (no /rosout and no parameter services unless asked)."""
    settings.setdefault('enable_rosout', False)
    settings.setdefault('start_parameter_services', False)
    return Node(name, **settings)


G = TypeVar('G')


def start_gateway(
    node: Node | None, name: str, settings: NodeKeywords, start: Callable[[Node, bool], G]
) -> G:
    """``start(node, own)``: on ``node``, or without one on a node of its own (``own``; see
    :func:`gateway_node`), which is destroyed again if the gateway does not start."""
    own = node is None
    if node is None:
        node = gateway_node(name, settings)
    try:
        return start(node, own)
    except BaseException:
        if own:
            node.destroy()
        raise


def publisher_qos(offered: Iterable[QoS], latched: bool = False) -> QoS:
    """The QoS of a publisher a client asked for: depth 1 transient local when it latches,
    else the QoS matched to the topic's other publishers (ROS 2's default without any)."""
    if latched:
        return QoS(1, durability=Durability.TRANSIENT_LOCAL)
    offers = list(offered)
    return matched_qos(offers) if offers else QoS()
