"""zros's own liveliness tokens beside a bridge's: which zros node exists, and which owns an entity.

Bridges announce ROS entities under ``@/<zid>/@ros2_lv`` and abort on shapes they do not know
there, so zros names its nodes in a key space of its own (bridges never parse it):

* ``@/<zid>/@zros_lv/NN/<node fqn, / as §>`` per node;
* ``@/<zid>/@zros_lv/EN/<node fqn>/<kind>/<key>/<type>`` per entity, linking it to its node.

Pure functions of their arguments.
"""

from __future__ import annotations

from dataclasses import dataclass

from zros.keyexpr.bridge import escape, unescape
from zros.keyexpr.kinds import EntityKind

ZROS_PREFIX = '@zros_lv'
#: liveliness selector of every zros owner token
ZROS_TOKENS = f'@/*/{ZROS_PREFIX}/**'


def node_token(zid: str, node_fqn: str) -> str:
    """The liveliness key announcing a zros node."""
    return f'@/{zid}/{ZROS_PREFIX}/NN/{escape(node_fqn)}'


def entity_token(zid: str, node_fqn: str, kind: EntityKind, key: str, type_name: str) -> str:
    """The liveliness key telling which zros node owns an entity."""
    return (
        f'@/{zid}/{ZROS_PREFIX}/EN/{escape(node_fqn)}/{kind.value}/'
        f'{escape(key)}/{escape(type_name)}'
    )


@dataclass(frozen=True)
class OwnedNode:
    """A zros node, from its ``NN`` token."""

    zid: str
    node: str  #: fully qualified name


@dataclass(frozen=True)
class OwnedEntity:
    """An entity and the zros node owning it, from an ``EN`` token."""

    zid: str
    kind: EntityKind
    key: str  #: the entity's Zenoh key (as the bridge token has it)
    type_name: str
    node: str  #: fully qualified name of the owner

    @property
    def entity(self) -> tuple[str, EntityKind, str, str]:
        """What identifies the entity among a session's bridge tokens."""
        return (self.zid, self.kind, self.key, self.type_name)


def parse_owner_token(key: str) -> OwnedNode | OwnedEntity | None:
    """Read a key under ``@/<zid>/@zros_lv``; None for shapes zros does not write."""
    parts = key.split('/')
    if len(parts) == 5 and parts[3] == 'NN':
        return OwnedNode(parts[1], unescape(parts[4]))
    if len(parts) == 8 and parts[3] == 'EN':
        try:
            kind = EntityKind(parts[5])
        except ValueError:
            return None
        node = unescape(parts[4])
        return OwnedEntity(parts[1], kind, unescape(parts[6]), unescape(parts[7]), node)
    return None
