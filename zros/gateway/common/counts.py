"""Per-client counts of what a client holds (subscriptions, calls waiting...), kept bounded:
a count that reaches zero leaves no key behind, so clients that came and went cost nothing."""

from __future__ import annotations

import collections
from collections.abc import Hashable
from typing import TypeVar

K = TypeVar('K', bound=Hashable)


def count_down(counts: collections.Counter[K], key: K) -> None:
    """One less for ``key``; its key goes at zero."""
    counts[key] -= 1
    if counts[key] <= 0:
        del counts[key]
