"""Renamed public names: the old one keeps working and says what replaces it."""

from __future__ import annotations

import warnings


def deprecated(old: str, new: str, stacklevel: int = 3) -> None:
    """Warn (DeprecationWarning, at the caller's caller) that ``old`` is now ``new``."""
    warnings.warn(
        f'{old} is deprecated: use {new} (same behaviour)',
        DeprecationWarning,
        stacklevel=stacklevel,
    )
