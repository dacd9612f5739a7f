"""What an action's client and server are made of alike: its type, name and key."""

from __future__ import annotations

from zros.actions.common import action_type
from zros.cdr.interfaces import ActionType
from zros.cdr.message import Message
from zros.keyexpr.kinds import EntityKind
from zros.runtime.entity import Entity


class ActionEntity(Entity):
    """An action's client or server: :meth:`_name_action` sets what both know of it."""

    action_type: ActionType
    type_name: str  #: ``pkg/action/Name``
    name: str  #: resolved
    Goal: type[Message]
    Result: type[Message]
    Feedback: type[Message]

    def _name_action(self, kind: EntityKind, name: str, action: str | ActionType) -> None:
        """Resolve ``action`` (the type) and ``name`` as the ``kind`` end's; its key."""
        context = self.context
        self.action_type = action_type(context.registry, action)
        self.type_name = self.action_type.__actiontype__
        self.name = self._resolve(kind, name)
        self.key = context.wire.key(self.name)
        self.Goal = self.action_type.Goal
        self.Result = self.action_type.Result
        self.Feedback = self.action_type.Feedback
        self._StatusArray = context.registry.get_class('action_msgs/msg/GoalStatusArray')
