"""Raw Zenoh requests and replies that look like a zros node's wire scheme, for tests that put
bytes on the wire themselves (rmw_zenoh needs attachments on both)."""

from __future__ import annotations

import itertools
import time
from typing import Any

import zenoh

from zros.keyexpr.attachment import Attachment
from zros.keyexpr.kinds import EntityKind
from zros.node import Node
from zros.wire import read_attachment

#: the GID raw test requests claim (any 16 bytes do)
RAW_GID = bytes(range(16))
_numbers = itertools.count(1)


def request_options(node: Node) -> dict[str, Any]:
    """Keyword arguments for ``session.get`` that make a request of ``node``'s wire."""
    if not node.scheme.attachments:
        return {}
    attachment = Attachment(next(_numbers), time.time_ns(), RAW_GID).encode()
    return {
        'attachment': attachment,
        'target': zenoh.QueryTarget.ALL_COMPLETE,
        'consolidation': zenoh.ConsolidationMode.NONE,
    }


def reply_options(query: Any) -> dict[str, Any]:
    """Keyword arguments for ``query.reply`` that echo the request's rmw_zenoh attachment."""
    request = read_attachment(query)
    if request is None:
        return {}
    return {'attachment': Attachment(request.sequence_number, time.time_ns(), request.gid).encode()}


def put_options(node: Node) -> dict[str, Any]:
    """Keyword arguments for ``publisher.put`` that make a publication of ``node``'s wire."""
    if not node.scheme.attachments:
        return {}
    return {'attachment': Attachment(next(_numbers), time.time_ns(), RAW_GID).encode()}


def service_key(node: Node, name: str, srv_type: str) -> str:
    """The Zenoh key of a service (or action part) as ``node`` would declare it."""
    wire = node.context.wire
    return wire.entity(EntityKind.SERVICE_SERVER, name, srv_type, node.registry, announce=False).key
