"""The errors a traced codec raises: the exception it met, as a CdrError that names the
message type, the field and (decoding) the offset."""

from __future__ import annotations

import struct

from zros.cdr.errors import CdrError


def decode_failure(type_name: str, path: str, offset: int, exc: Exception, size: int) -> Exception:
    """What a traced decoder raises for ``exc``, met in ``path`` at ``offset`` of ``size`` bytes."""
    if isinstance(exc, CdrError):
        return exc
    reason = str(exc) or type(exc).__name__
    if isinstance(exc, struct.error) or (isinstance(exc, ValueError) and 'buffer' in reason):
        reason = f'the buffer ends too early ({size} bytes)'
    elif isinstance(exc, UnicodeDecodeError):
        reason = f'invalid UTF-8 ({exc.reason} at byte {exc.start} of the string)'
    where = f' field {path!r}' if path else ''
    return CdrError(
        f'cannot decode {type_name}:{where} at byte {offset}: {reason}',
        type_name=type_name,
        field=path,
        offset=offset,
    )


def encode_failure(type_name: str, path: str, exc: Exception) -> Exception:
    """What a traced encoder raises for ``exc``, met in ``path``."""
    if isinstance(exc, CdrError):
        return exc
    reason = str(exc) or type(exc).__name__
    if isinstance(exc, AttributeError):
        reason = f'a value has the wrong type ({reason})'
    where = f' field {path!r}' if path else ''
    return CdrError(f'cannot encode {type_name}:{where}: {reason}', type_name=type_name, field=path)
