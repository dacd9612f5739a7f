"""The errors of the transport layer (a module of their own: every other module raises them)."""

from __future__ import annotations

import re
from collections.abc import Iterable

from zros.errors import SettingError, ZrosError
from zros.transport.credentials import HIDDEN, scrub

_LOCATION = re.compile(r'\s*\bat /\S+?\.rs:\d+\.?')
#: a line of the source excerpt Zenoh's JSON5 errors quote (it may hold a password)
_EXCERPT = re.compile(r'^\s*(\d+\s*)?\|')
#: the offending value in a serde error ("invalid type: integer `42`", "unknown variant `x`")
_FOUND = re.compile(
    r'((?:invalid type|invalid value): [a-z ]+?|unknown variant) (`[^`]*`|\\?"(?:[^"\\]|\\.)*?\\?")'
)
#: serde's message inside Zenoh's Rust debug text
_SERDE = re.compile(
    r'(?:Json5Err\()?(?:JSON error: )?Message \{ msg: "(?P<msg>(?:[^"\\]|\\.)*)", location: '
    r'(?:Some\(Location \{ line: (?P<line>\d+), column: (?P<column>\d+) \}\)|None) \}\)?'
)


def _serde(match: re.Match[str]) -> str:
    message = match['msg'].replace('\\"', '"')
    return (
        f'{message} (line {match["line"]}, column {match["column"]})' if match['line'] else message
    )


class TransportError(ZrosError, ConnectionError):
    """The Zenoh network could not be reached or the session failed."""


class TlsFileError(TransportError):
    """A TLS file is missing, unreadable, or not what its place needs (says which, and why)."""


def zenoh_reason(error: BaseException, secrets: Iterable[str | None] = ()) -> str:
    """Zenoh's error text on one line, without Rust source locations, quoted excerpts of the
    settings or the values it found there (any may be a secret), and with ``secrets`` hidden."""
    lines = _LOCATION.sub('', str(error)).splitlines()
    text = ' '.join(line.strip() for line in lines if line.strip() and not _EXCERPT.match(line))
    text = _FOUND.sub(rf'\1 {HIDDEN}', text)
    return scrub(_SERDE.sub(_serde, text), secrets)


class EndpointError(SettingError):
    """An endpoint zros cannot make sense of (a usage error: ``zros`` exits with 2)."""


class CertificateError(ZrosError):
    """Certificates cannot be made here (missing package, files in the way, bad host name)."""
