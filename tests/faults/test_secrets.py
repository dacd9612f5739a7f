"""Passwords and private keys never show: reprs, errors (Zenoh's own included), logs, ``zros
doctor`` (issue 15.8)."""

from __future__ import annotations

import json
import logging
import os
import stat
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
import zenoh

from tests.cli.conftest import ZROS
from zros.transport import Router, Tls, Transport, TransportConfig, TransportError, start_router

PASSWORD = 'hunter2-Zq8'
KEY_TEXT = 'S3CRETKEYBASE64'


@pytest.fixture
def password_router(tmp_path: Path) -> Iterator[Router]:
    users = tmp_path / 'users'
    users.write_text(f'laptop:{PASSWORD}\n')
    with start_router(zenoh={'transport/auth/usrpwd/dictionary_file': str(users)}) as router:
        yield router


def config_file_with_a_typo(folder: Path) -> Path:
    """A Zenoh file whose password lacks its quotes: Zenoh quotes the line in its error."""
    file = folder / 'zenoh.json5'
    file.write_text(
        f'{{transport: {{auth: {{usrpwd: {{user: "laptop", password: {PASSWORD}}}}}}}}}'
    )
    return file


def test_repr_and_str_hide_passwords_and_secret_settings(tmp_path: Path) -> None:
    key = tmp_path / 'me.key'
    key.write_text(f'-----BEGIN PRIVATE KEY-----\n{KEY_TEXT}\n-----END PRIVATE KEY-----\n')
    (tmp_path / 'ca.pem').write_text('x')
    config = TransportConfig.create(
        user='laptop',
        password=PASSWORD,
        tls=Tls(str(tmp_path / 'ca.pem'), str(tmp_path / 'ca.pem'), str(key)),
        zenoh={
            'transport/link/tls/listen_private_key_base64': KEY_TEXT,
            'transport/auth/usrpwd': {'user': 'robot', 'password': 'nested-secret'},
            'transport/link/tx/lease': 1000,
        },
    )
    for text in (repr(config), str(config)):
        assert PASSWORD not in text and KEY_TEXT not in text and 'nested-secret' not in text
        assert "password='***'" in text and "'user': 'robot'" in text
        assert str(key) in text and "'transport/link/tx/lease': 1000" in text
    assert config.password == PASSWORD  # hidden from view, not lost
    assert set(config.secrets()) >= {PASSWORD, KEY_TEXT, 'nested-secret'}


def test_zenoh_errors_that_quote_a_secret_are_scrubbed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Zenoh quotes the value it could not take, and the source line of a bad file."""
    with pytest.raises(TransportError) as info:
        TransportConfig.create(zenoh={'transport/auth/usrpwd/password': 424242}).to_zenoh()
    assert '424242' not in str(info.value)
    assert 'transport/auth/usrpwd/password' in str(info.value)
    with pytest.raises(TransportError) as info:
        start_router(zenoh={'transport/auth/usrpwd/password': 424242})
    assert '424242' not in str(info.value)
    file = config_file_with_a_typo(tmp_path)
    monkeypatch.setenv('ZENOH_CONFIG', str(file))
    with pytest.raises(TransportError) as info:
        TransportConfig.create().to_zenoh()
    assert PASSWORD not in str(info.value) and str(file) in str(info.value)
    assert '\n' not in str(info.value)


def test_refusals_and_logs_never_show_the_password(
    password_router: Router, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG)
    wrong = f'{PASSWORD}-wrong'
    config = TransportConfig.create(connect=password_router.endpoint, user='laptop', password=wrong)
    with pytest.raises(TransportError) as info:
        Transport(config)
    assert "is the user 'laptop' and its password right?" in str(info.value)
    assert wrong not in str(info.value) and wrong not in repr(info.value)
    Transport(
        TransportConfig.create(connect=password_router.endpoint, user='laptop', password=PASSWORD)
    ).close()
    assert PASSWORD not in caplog.text


def test_the_password_file_lives_only_while_zenoh_opens() -> None:
    from zros.transport.credentials import password_dictionary

    config = zenoh.Config()
    with password_dictionary(config, 'laptop', PASSWORD):
        path = Path(json.loads(config.get_json('transport/auth/usrpwd/dictionary_file')))
        assert path.read_text() == f'laptop:{PASSWORD}\n'
        assert stat.S_IMODE(path.stat().st_mode) == 0o600
        assert stat.S_IMODE(path.parent.stat().st_mode) == 0o700
    assert not path.exists() and not path.parent.exists()
    with pytest.raises(ValueError, match='without ":"'):
        TransportConfig.create(user='a:b', password=PASSWORD)
    with pytest.raises(ValueError, match='on one line'):
        TransportConfig.create(user='laptop', password='two\nlines')


def doctor(env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    return subprocess.run(
        [ZROS, 'doctor', '--wait', '0', '--listen', '0'],
        capture_output=True,
        text=True,
        timeout=60,
        env={**os.environ, **env},
        check=False,
    )


def test_zros_doctor_never_prints_secrets(password_router: Router, tmp_path: Path) -> None:
    refused = doctor(
        {
            'ZROS_CONNECT': password_router.endpoint,
            'ZROS_USER': 'laptop',
            'ZROS_PASSWORD': f'{PASSWORD}-wrong',
        }
    )
    assert refused.returncode == 1 and 'FAIL' in refused.stdout
    assert PASSWORD not in refused.stdout + refused.stderr
    accepted = doctor(
        {'ZROS_CONNECT': password_router.endpoint, 'ZROS_USER': 'laptop', 'ZROS_PASSWORD': PASSWORD}
    )
    assert 'connected to' in accepted.stdout
    assert PASSWORD not in accepted.stdout + accepted.stderr
    file = config_file_with_a_typo(tmp_path)
    broken = doctor({'ZENOH_CONFIG': str(file), 'ZROS_CONNECT': password_router.endpoint})
    assert broken.returncode == 1 and 'Traceback' not in broken.stderr
    assert str(file) in broken.stdout and PASSWORD not in broken.stdout + broken.stderr
