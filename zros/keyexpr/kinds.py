"""What both wire schemes share: the kinds of entities they announce."""

from __future__ import annotations

import enum


class EntityKind(str, enum.Enum):
    """The entity kinds of the bridge's tokens, by their two-letter code."""

    PUBLISHER = 'MP'
    SUBSCRIBER = 'MS'
    SERVICE_SERVER = 'SS'
    SERVICE_CLIENT = 'SC'
    ACTION_SERVER = 'AS'
    ACTION_CLIENT = 'AC'

    @property
    def has_qos(self) -> bool:
        """Whether tokens of this kind carry a QoS (publishers and subscribers)."""
        return self in (EntityKind.PUBLISHER, EntityKind.SUBSCRIBER)
