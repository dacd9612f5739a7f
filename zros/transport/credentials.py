"""Passwords and private keys: hidden from reprs and errors, handed to Zenoh only as it needs.

Zenoh accepts a user and password on incoming links only from a dictionary *file*
(``transport/auth/usrpwd/dictionary_file``, lines ``user:password``), and reads that file once,
while the session opens (measured with eclipse-zenoh 1.10: a file removed right after ``open``
still admits the user). So a listening node or router with a password gets a file readable by
its owner only, in a private temporary folder, that exists just while Zenoh opens.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from zros.errors import SettingError

if TYPE_CHECKING:
    from zenoh import Config

    from zros.cdr.model import JsonValue

HIDDEN = '***'
DICTIONARY = 'transport/auth/usrpwd/dictionary_file'


def secret_setting(path: str) -> bool:
    """Whether a Zenoh setting (by path) holds a secret's content, not the name of a file."""
    last = path.rstrip('/').rpartition('/')[2].lower()
    return 'password' in last or ('private_key' in last and last.endswith(('_base64', '_pem')))


def redact(settings: Mapping[str, JsonValue], prefix: str = '') -> dict[str, JsonValue]:
    """``settings`` (Zenoh paths to values, nested or not) with every secret value hidden."""
    shown: dict[str, JsonValue] = {}
    for key, value in settings.items():
        path = f'{prefix}/{key}' if prefix else str(key)
        if isinstance(value, Mapping):
            shown[key] = redact(value, path)
        elif secret_setting(path) and value is not None:
            shown[key] = HIDDEN
        else:
            shown[key] = value
    return shown


def secret_values(settings: Mapping[str, JsonValue], prefix: str = '') -> list[str]:
    """The secret values in ``settings`` (see :func:`redact`), as text."""
    found: list[str] = []
    for key, value in settings.items():
        path = f'{prefix}/{key}' if prefix else str(key)
        if isinstance(value, Mapping):
            found += secret_values(value, path)
        elif secret_setting(path) and value:
            found.append(str(value))
    return found


def key_file_secrets(path: str | None) -> list[str]:
    """The lines of a private key file's body, to scrub from text (nothing if unreadable)."""
    if path is None:
        return []
    try:
        text = Path(path).read_text(errors='replace')
    except OSError:
        return []
    return [line.strip() for line in text.splitlines() if line.strip() and '-----' not in line]


def scrub(text: str, secrets: Iterable[str | None]) -> str:
    """``text`` with every secret replaced by ``***`` (the longest first)."""
    for secret in sorted(filter(None, secrets), key=len, reverse=True):
        text = text.replace(secret, HIDDEN)
    return text


def check_user(user: str, password: str | None) -> None:
    """A user name and password that a Zenoh dictionary line can carry (SettingError if not)."""
    if password is None:
        raise SettingError('a user needs a password (password=)')
    if not user or ':' in user or any(c in user for c in '\r\n'):
        raise SettingError(f'user name {user!r}: give a non-empty name without ":" or line breaks')
    if not password or any(c in password for c in '\r\n'):
        raise SettingError('the password must be non-empty, on one line')


@contextlib.contextmanager
def password_dictionary(config: Config, user: str | None, password: str | None) -> Iterator[None]:
    """While open, ``config`` (a ``zenoh.Config``) names a private file that admits ``user``.

    Does nothing without a user, or when the settings name a dictionary file already.
    """
    if user is None or password is None or json.loads(config.get_json(DICTIONARY)):
        yield
        return
    folder = tempfile.mkdtemp(prefix='zros-auth-')  # mode 0700
    path = os.path.join(folder, 'users')
    descriptor = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    try:
        with os.fdopen(descriptor, 'w') as file:
            file.write(f'{user}:{password}\n')
        config.insert_json5(DICTIONARY, json.dumps(path))
        yield
    finally:
        shutil.rmtree(folder, ignore_errors=True)
