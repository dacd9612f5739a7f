"""The root of every exception zros raises."""

from __future__ import annotations


class ZrosError(Exception):
    """Base class of all zros errors."""

    #: the message for a ``zros`` command's user when it differs from ``str(error)``: it names
    #: flags and environment variables where the message for a program names arguments
    command_line: str | None = None


def command_line_text(error: BaseException) -> str:
    """What the ``zros`` command prints for ``error``."""
    text = error.command_line if isinstance(error, ZrosError) else None
    return text or str(error)


class SettingError(ZrosError, ValueError):
    """A setting that cannot work as given (a usage error: the ``zros`` command exits with 2)."""
