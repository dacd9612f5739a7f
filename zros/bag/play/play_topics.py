"""What a playback publishes for each recorded topic: its QoS, its class, its name."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

from zros.bag.errors import PlayerError
from zros.bag.read.types import how_to_define
from zros.cdr import TypeRegistry
from zros.errors import ZrosError
from zros.qos import Congestion, Durability, History, QoS, Reliability

if TYPE_CHECKING:
    from zros.bag.read.source import Connection
    from zros.cdr import Message
    from zros.node import Node


def playback_qos(offered: Iterable[QoS]) -> QoS:
    """The publisher QoS for a topic from its recorded offers: latched (transient local) and
    best effort only when every offer was, as deep as the deepest; ROS 2's default without.

    Reliable publishers block on a full link rather than drop (Zenoh congestion control): a
    player is not a control loop, and a burst (express ``/tf`` above all: 2 messages queued per
    priority) would otherwise lose messages whenever the link's thread is late by 1 ms.
    """
    offers = list(offered)
    if not offers:
        return QoS(10, congestion=Congestion.BLOCK)
    keep_all = all(q.keep_all for q in offers)
    reliable = any(q.reliable for q in offers)
    return QoS(
        max(q.depth for q in offers),
        Reliability.RELIABLE if reliable else Reliability.BEST_EFFORT,
        Durability.TRANSIENT_LOCAL
        if all(q.transient_local for q in offers)
        else Durability.VOLATILE,
        History.KEEP_ALL if keep_all else History.KEEP_LAST,
        congestion=Congestion.BLOCK if reliable else None,
    )


def message_class(node: Node, connection: Connection) -> type[Message]:
    """The class for a connection's type: the node's, else one built from the bag's definition."""
    try:
        return node.registry.get_class(connection.type_name)
    except ZrosError as exc:
        # an empty message's definition is '' in format ros2msg; no definition has no format
        if connection.definition_format != 'ros2msg':
            raise PlayerError(
                f'cannot play {connection.topic}: the bag has no definition of '
                f'{connection.type_name} and zros knows none; {how_to_define(connection.type_name)}'
            ) from exc
    registry = TypeRegistry(distro=node.registry.distro)
    registry.register_bundle(connection.type_name, connection.definition, str(connection.topic))
    return registry.get_class(connection.type_name)


def is_service_event(connection: Connection) -> bool:
    """Whether a connection is a recorded service event topic (``…/srv/X_Event``), which
    rosbag2 republishes only on request and zros's publishers do not take."""
    parts = connection.type_name.split('/')
    return len(parts) == 3 and parts[1] == 'srv' and parts[2].endswith('_Event')


def parse_remap(rules: Mapping[str, str] | Iterable[str] | None) -> dict[str, str]:
    """``{'/a': '/b'}`` or ``['/a:=/b']`` as a dict."""
    if rules is None:
        return {}
    if isinstance(rules, Mapping):
        return dict(rules)
    result = {}
    for rule in rules:
        source, sep, target = rule.partition(':=')
        if not sep or not source or not target:
            raise PlayerError(f'a remap rule is /from:=/to, not {rule!r}')
        result[source] = target
    return result
