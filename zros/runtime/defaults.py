"""The default node of the process (``zros.init``), for entities made without ``node=``.

The module API (:mod:`zros.api`) sets it; entities below that layer only read it here.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from zros.errors import ZrosError
from zros.runtime.context import NodeContext


class NotInitializedError(ZrosError, RuntimeError):
    """A module-level call needs ``zros.init(name)`` first."""


class NodeLike(Protocol):
    """What entities need of a node: its context."""

    @property
    def context(self) -> NodeContext:
        """The node's session, wire, registry, executor, clock and names."""


_default: NodeLike | None = None
_factory: Callable[[], NodeLike] | None = None


def set_default_node(node: NodeLike | None) -> None:
    """Make ``node`` the default (None: there is none)."""
    global _default  # noqa: PLW0603
    _default = node


def set_default_node_factory(factory: Callable[[], NodeLike] | None) -> None:
    """Make the default node with ``factory`` when first needed (``zros.init()`` without a name)."""
    global _factory  # noqa: PLW0603
    _factory = factory


def default_node() -> NodeLike:
    """The node ``zros.init`` created (or makes now); NotInitializedError before."""
    if _default is None and _factory is not None:
        return _factory()
    if _default is None:
        raise NotInitializedError(
            'no default node: call zros.init("my_node") first, or pass node= explicitly'
        )
    return _default
