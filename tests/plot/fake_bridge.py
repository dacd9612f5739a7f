"""A stand-in for zenoh-bridge-ros2dds on a session of the test: its liveliness tokens (the
bridge's own and one per ROS entity it routes) and its admin space (version, config)."""

from __future__ import annotations

import json
from typing import Any

from zros.keyexpr.bridge import EntityToken, TokenQoS
from zros.keyexpr.kinds import EntityKind
from zros.qos import QoS
from zros.transport import Transport


class FakeBridge:
    """Announce ``entities`` ((kind, ROS name, type)) as a bridge with ``namespace`` would."""

    def __init__(
        self,
        transport: Transport,
        entities: list[tuple[EntityKind, str, str]],
        namespace: str = '/',
        nodename: str = 'zenoh_bridge_ros2dds',
    ) -> None:
        session = transport.session
        zid = transport.zid
        config = json.dumps({'namespace': namespace, 'nodename': nodename})

        def answer(query: Any) -> None:
            item = str(query.key_expr).rsplit('/', 1)[-1]
            with query:
                if item == 'version':
                    query.reply(f'@/{zid}/ros2/version', json.dumps('v1.10.0'))
                elif item == 'config':
                    query.reply(f'@/{zid}/ros2/config', config)

        self.queryable = session.declare_queryable(f'@/{zid}/ros2/**', answer)
        prefix = '' if namespace == '/' else namespace[1:] + '/'
        keys = [f'@/{zid}/@ros2_lv']
        for kind, name, type_name in entities:
            qos = TokenQoS.from_qos(QoS(10)) if kind.has_qos else None
            keys.append(EntityToken(kind, zid, prefix + name[1:], type_name, qos).format())
        liveliness = session.liveliness()
        self.tokens = [liveliness.declare_token(key) for key in keys]

    def close(self) -> None:
        """Withdraw the tokens and the admin space."""
        for token in self.tokens:
            token.undeclare()
        self.queryable.undeclare()
