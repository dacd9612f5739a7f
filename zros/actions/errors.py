"""The errors of action clients and servers."""

from __future__ import annotations

from zros.errors import ZrosError


class ActionError(ZrosError):
    """An action goal could not be sent, was rejected, or ended without a result."""


class GoalRejectedError(ActionError):
    """The server rejected the goal."""
