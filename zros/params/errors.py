"""The errors of parameter operations."""

from __future__ import annotations

from zros.errors import ZrosError


class ParameterError(ZrosError):
    """A parameter operation failed (the message says why)."""


class ParameterNotDeclaredError(ParameterError, KeyError):
    """The parameter is not declared (and the node does not allow undeclared ones)."""

    def __str__(self) -> str:  # KeyError would repr the message
        return str(self.args[0])


class ParameterTimeoutError(ParameterError, TimeoutError):
    """The node did not answer in time."""


class NodeNotFoundError(ParameterError, LookupError):
    """No node of that name serves parameters."""
