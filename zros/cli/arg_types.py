"""argparse types the commands share: a port, a count of at least one, a size in bytes."""

from __future__ import annotations

import argparse


def port_number(text: str) -> int:
    """An argparse type: a TCP port, 0 to 65535 (0: any free one)."""
    value = int(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f'a port is 0 to 65535, not {text}')
    return value


def at_least_one(text: str) -> int:
    """An argparse type: an integer of at least 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f'must be at least 1, not {text}')
    return value


_UNITS = {'': 1, 'k': 1000, 'kb': 1000, 'kib': 1024, 'm': 1000**2, 'mb': 1000**2,
          'mib': 1024**2, 'g': 1000**3, 'gb': 1000**3, 'gib': 1024**3}  # fmt: skip


def byte_count(text: str) -> int:
    """An argparse type: a size of at least 1 byte, as ``33554432``, ``32MiB`` or ``500kB``."""
    spelled = text.strip().lower()
    unit = spelled.lstrip('0123456789.')
    factor = _UNITS.get(unit.strip())
    try:
        size = int(float(spelled[: len(spelled) - len(unit)]) * factor) if factor else 0
    except ValueError:
        size = 0
    if size < 1:
        raise argparse.ArgumentTypeError(
            f'a size in bytes, as 33554432, 32MiB or 500kB, of at least 1 byte, not {text}'
        )
    return size
