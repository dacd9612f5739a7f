"""Which names a gateway offers: allow and deny lists, as regular expressions (foxglove_bridge's
whitelists) or globs (rosbridge's ``topics_glob``)."""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Iterable

from zros.gateway.common.errors import GatewayError


def compile_regex(pattern: str, refusal: str) -> re.Pattern[str]:
    """``pattern`` compiled; GatewayError ``'<refusal>: <why>'`` when it is not a Python regular
    expression."""
    try:
        return re.compile(pattern)
    except re.error as exc:
        raise GatewayError(f'{refusal}: {exc}') from None


class NameFilter:
    """Which names pass: those matching an ``include`` pattern (every name when there is
    none) and no ``exclude`` pattern. Patterns match the whole name."""

    def __init__(
        self, include: Iterable[re.Pattern[str]] = (), exclude: Iterable[re.Pattern[str]] = ()
    ):
        self.include = list(include)
        self.exclude = list(exclude)

    @classmethod
    def regexes(
        cls, include: Iterable[str] | None = None, exclude: Iterable[str] | None = None
    ) -> NameFilter:
        """Python regular expressions, as foxglove_bridge's ``topic_whitelist`` (full match)."""

        def compile_all(patterns: Iterable[str] | None) -> list[re.Pattern[str]]:
            return [
                compile_regex(p, f'the pattern {p!r} is not a valid regex') for p in patterns or ()
            ]

        return cls(compile_all(include), compile_all(exclude))

    @classmethod
    def globs(
        cls, include: Iterable[str] | None = None, exclude: Iterable[str] | None = None
    ) -> NameFilter:
        """Shell-style globs (``/camera/*``), as rosbridge's ``topics_glob``."""

        def compile_all(patterns: Iterable[str] | None) -> list[re.Pattern[str]]:
            return [re.compile(fnmatch.translate(p)) for p in patterns or ()]

        return cls(compile_all(include), compile_all(exclude))

    def __call__(self, name: str) -> bool:
        if self.include and not any(p.fullmatch(name) for p in self.include):
            return False
        return not any(p.fullmatch(name) for p in self.exclude)

    def __repr__(self) -> str:
        include = [p.pattern for p in self.include]
        return f'<NameFilter include={include} exclude={[p.pattern for p in self.exclude]}>'
