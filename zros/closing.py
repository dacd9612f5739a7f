"""The one ``with`` of zros: an object that is closed at the end of a ``with`` block."""

from __future__ import annotations

from typing import TypeVar

C = TypeVar('C', bound='Closing')


class Closing:
    """``with thing:`` closes ``thing`` (its :meth:`close`) when the block ends, however."""

    def close(self) -> None:
        """Release what it holds; safe to call twice."""
        raise NotImplementedError

    def __enter__(self: C) -> C:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
