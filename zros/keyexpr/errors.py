"""The errors of names, tokens and attachments."""

from __future__ import annotations

from zros.errors import ZrosError


class InvalidNameError(ZrosError, ValueError):
    """A topic, service, node name or namespace breaks a ROS 2 naming rule."""

    def __init__(self, kind: str, name: str, index: int, rule: str) -> None:
        pointer = f'\n    {name!r}\n     {" " * index}^' if name else ''
        super().__init__(f'invalid {kind} {name!r}: {rule}{pointer}')
        self.name = name
        self.index = index
        self.rule = rule


class TokenError(ZrosError, ValueError):
    """A liveliness token is not in the bridge's format (or zros refuses to write it)."""


class AttachmentError(ZrosError, ValueError):
    """Bytes that are not an rmw_zenoh attachment."""
