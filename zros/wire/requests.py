"""The queries a server holds, each answered exactly once (plain form: every query admitted).

A wire scheme with rules for requests (rmw_zenoh's attachments) subclasses :class:`Requests`;
servers only call :meth:`admit`, :meth:`reply` and :meth:`fail`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zenoh import Query


class Requests:
    """The requests of one server (``name`` in errors); error replies start with
    ``error_prefix``. This form admits every query and replies without an attachment."""

    def __init__(self, name: str, error_prefix: str) -> None:
        self.name = name
        self.error_prefix = error_prefix

    def admit(self, query: Query) -> bool:
        """Whether to handle ``query``; refused ones got their error reply already."""
        return True

    def reply(self, query: Query, payload: bytes | bytearray) -> None:
        """Send the reply and end the query."""
        attachment = self._reply_attachment(query)
        self._finish(query, lambda: query.reply(query.key_expr, payload, attachment=attachment))

    def fail(self, query: Query, reason: str) -> None:
        """Send an error reply (``error_prefix`` + reason) and end the query."""
        self._finish(query, lambda: query.reply_err(self.error_prefix + reason))

    def _reply_attachment(self, query: Query) -> bytes | None:
        return None

    def _forget(self, query: Query) -> None:
        """The query is being answered: drop what was kept about it."""

    def _finish(self, query: Query, answer: Callable[[], object]) -> None:
        self._forget(query)
        try:
            answer()
        finally:
            query.drop()  # type: ignore[no-untyped-call]  # untyped in zenoh's stub
