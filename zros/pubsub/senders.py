"""Who sent a sample a subscription drops, named for the log: with the node that announced
it, if the graph knows one, and its session."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from zros.graph import graph_of
from zros.keyexpr.kinds import EntityKind
from zros.runtime.context import NodeContext

if TYPE_CHECKING:
    from zenoh import Sample

_log = logging.getLogger('zros')


def describe_sender(sample: Sample, key: str, context: NodeContext, topic: str) -> str:
    """A log-friendly name for the sender of ``sample`` (``key`` from
    ``zros.runtime.drops.sender_key``): with the node that announced it, if any, and its
    session."""
    try:
        return _describe(sample, key, context, topic)
    except Exception:  # the session is closing: the bare key still names the sender
        _log.debug('cannot look up the sender %s', key, exc_info=True)
        return key


def _describe(sample: Sample, key: str, context: NodeContext, topic: str) -> str:
    kind, _, ident = key.partition(':')
    publishers = graph_of(context.transport).endpoints((EntityKind.PUBLISHER,))
    if kind == 'gid':
        owners = {e.node or e.zid for e in publishers if e.gid is not None and e.gid.hex() == ident}
        owner = f'of {", ".join(sorted(owners))}' if owners else 'announced by no one'
        stamp = sample.timestamp
        session = f', via session {stamp.get_id()}' if stamp is not None else ''
        return f'publisher {ident} ({owner}{session})'
    if kind == 'source':
        return f'source {ident}'
    if kind == 'session':
        if ident in {str(z) for z in context.transport.session.info.routers_zid()}:
            return (
                f'router {ident} (the sender does not timestamp its messages, so the first '
                'router did: senders behind it cannot be told apart)'
            )
        namespace = context.wire.namespace
        owners = {
            e.node or f'a bridged node (bridge {e.zid})'
            for e in publishers
            if e.zid == ident and e.ros_name(namespace) == topic
        }
        names = ', '.join(sorted(owners)) if owners else f'no publisher of {topic} announced'
        return f'session {ident} ({names})'
    return 'an unknown sender (no timestamp, no source information)'
