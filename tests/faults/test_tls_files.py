"""Bad TLS files are named, with what is wrong and how to fix it (issue 15.4).

Each case gives a node one bad file and dials a mutual-TLS router, as a user with a copy-paste
slip would; the error must be a TransportError naming that file, never ``ssl.SSLError``.
"""

from __future__ import annotations

import os
import subprocess
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

pytest.importorskip('cryptography', reason='the test extra (cryptography) is not installed')

from cryptography.hazmat.primitives import serialization

from tests.cli.conftest import ZROS
from tests.faults.certs import by_name, leaf
from zros.transport import Router, Tls, Transport, TransportConfig, TransportError, start_router
from zros.transport.pki import Certificates, make_certificates

#: the fix a program's error names, and the one the zros command's names
FIX, CLI_FIX = 'zros.transport.pki.make_certificates(folder)', '`zros tls init FOLDER`'


@pytest.fixture(scope='module')
def pki(tmp_path_factory: pytest.TempPathFactory) -> Certificates:
    return make_certificates(tmp_path_factory.mktemp('pki'))


@pytest.fixture(scope='module')
def other(tmp_path_factory: pytest.TempPathFactory) -> Certificates:
    return make_certificates(tmp_path_factory.mktemp('other'))


@pytest.fixture
def router(pki: Certificates) -> Iterator[Router]:
    with start_router('tls/127.0.0.1:0', zenoh=pki.router_settings(mutual=True)) as running:
        yield running


def refused(router: Router, files: tuple[str, str, str], mode: str = 'client') -> TransportError:
    """The error of a node dialing ``router`` with TLS files (CA, certificate, key)."""
    connect = by_name(router)
    with pytest.raises(TransportError) as info:
        # a missing file is refused when the settings are made, the others when used
        Transport(TransportConfig.create(connect=connect, tls=Tls(*files), mode=mode))
    return info.value


def refusal(router: Router, files: tuple[str, str, str], mode: str = 'client') -> str:
    """The message of :func:`refused`."""
    return str(refused(router, files, mode))


def write(folder: Path, name: str, data: bytes | str) -> str:
    path = folder / name
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return str(path)


def der(pem: Path, folder: Path) -> str:
    from cryptography import x509

    certificate = x509.load_pem_x509_certificate(pem.read_bytes())
    return write(folder, 'router.der', certificate.public_bytes(serialization.Encoding.DER))


def encrypted(key: Path, folder: Path) -> str:
    loaded = serialization.load_pem_private_key(key.read_bytes(), None)
    data = loaded.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.BestAvailableEncryption(b'passphrase'),
    )
    return write(folder, 'locked.key', data)


#: name -> (which file is bad: 'ca' | 'certificate' | 'key', how to make it, words of the error)
CASES: dict[str, tuple[str, Callable[[Certificates, Certificates, Path], str], str]] = {
    'CA not PEM': ('ca', lambda p, o, d: write(d, 'ca.txt', 'hello\n'), 'is not a PEM file'),
    'CA empty': ('ca', lambda p, o, d: write(d, 'ca.pem', ''), 'is empty'),
    'CA is a key': ('ca', lambda p, o, d: str(p.folder / 'ca.key'), 'holds a private key'),
    'CA is DER': ('ca', lambda p, o, d: der(p.ca, d), 'is DER (binary)'),
    'CA is a folder': ('ca', lambda p, o, d: str(d), 'is a folder'),
    'CA missing': ('ca', lambda p, o, d: str(d / 'nope.pem'), 'does not exist'),
    'certificate not PEM': (
        'certificate',
        lambda p, o, d: write(d, 'me.pem', 'not a certificate'),
        'is not a PEM file',
    ),
    'certificate is a key': (
        'certificate',
        lambda p, o, d: str(p.client_key('laptop')),
        'holds a private key, not a certificate',
    ),
    'certificate expired': (
        'certificate',
        lambda p, o, d: str(leaf(p, d / 'old', valid_days=(-30, -1))[0]),
        'expired on',
    ),
    'key not PEM': ('key', lambda p, o, d: write(d, 'me.key', 'garbage'), 'is not a PEM file'),
    'key empty': ('key', lambda p, o, d: write(d, 'me.key', ''), 'is empty'),
    'key is a certificate': (
        'key',
        lambda p, o, d: str(p.client_certificate('laptop')),
        'holds a certificate, not a private key',
    ),
    'key of another certificate': (
        'key',
        lambda p, o, d: str(o.client_key('laptop')),
        'does not belong to the certificate',
    ),
    'key encrypted': (
        'key',
        lambda p, o, d: encrypted(p.client_key('laptop'), d),
        'is encrypted with a passphrase',
    ),
}


@pytest.mark.parametrize('case', CASES)
def test_a_bad_tls_file_is_named(
    case: str, router: Router, pki: Certificates, other: Certificates, tmp_path: Path
) -> None:
    role, make, words = CASES[case]
    files = {
        'ca': str(pki.ca),
        'certificate': str(pki.client_certificate('laptop')),
        'key': str(pki.client_key('laptop')),
    }
    bad = make(pki, other, tmp_path)
    files[role] = bad
    error = refused(router, (files['ca'], files['certificate'], files['key']))
    message, shell = str(error), error.command_line or str(error)
    assert bad in message and words in message
    assert '\n' not in message
    assert FIX in message or 'openssl' in message
    # a program is told what to call, the zros command's user what to type: never the other
    assert 'zros tls init' not in message and 'make_certificates' not in shell
    assert CLI_FIX in shell or 'openssl' in shell
    assert 'zenoh-bridge-ros2dds' not in message + shell  # a bad file: no router is to blame


def test_a_peer_with_a_client_only_certificate_is_told(
    router: Router, pki: Certificates, tmp_path: Path
) -> None:
    """Certificates from zros before peers listened on TLS cannot serve: said, not a silent
    peer that no other peer accepts."""
    certificate, key = leaf(pki, tmp_path / 'old_client', server=False)
    error = refused(router, (str(pki.ca), str(certificate), str(key)), mode='peer')
    message, shell = str(error), error.command_line or ''
    assert str(certificate) in message and 'is for clients only' in message
    assert "mode='client'" in message and 'make_certificates' in message
    assert 'zros tls init' not in message and '--mode' not in message
    assert shell.startswith(f'the certificate {certificate} is for clients only')
    assert '--mode client' in shell and CLI_FIX in shell
    assert "mode='client'" not in shell and 'make_certificates' not in shell
    # as a client it is still fine: clients do not listen
    connect = by_name(router)
    config = TransportConfig.create(
        connect=connect, tls=Tls(str(pki.ca), str(certificate), str(key))
    )
    Transport(config).close()


def test_the_command_line_names_a_bad_tls_file(router: Router, tmp_path: Path) -> None:
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    ca = write(tmp_path, 'ca.pem', 'not a certificate')
    env = dict(os.environ, ZROS_CONNECT=router.endpoint, ZROS_TLS_CA=ca)
    result = subprocess.run(
        [ZROS, 'topic', 'list'], capture_output=True, text=True, timeout=60, env=env, check=False
    )
    assert result.returncode == 1
    assert result.stderr.count('\n') == 1 and 'Traceback' not in result.stderr
    assert result.stderr.startswith(f'zros: error: the CA certificate {ca} is not a PEM file')
    assert CLI_FIX in result.stderr and 'make_certificates' not in result.stderr


def test_a_peer_listening_where_its_certificate_does_not_name_is_told(pki: Certificates) -> None:
    """The client certificates name localhost, 127.0.0.1 and ::1: a peer listening on
    127.0.0.2 is refused before it opens, each reader told its own way out."""
    tls = Tls(str(pki.ca), str(pki.client_certificate('laptop')), str(pki.client_key('laptop')))
    config = TransportConfig.create(
        connect='tls/127.0.0.1:1', mode='peer', listen='tls/127.0.0.2:0', tls=tls
    )
    with pytest.raises(TransportError) as info:
        Transport(config)
    message, shell = str(info.value), info.value.command_line or ''
    assert 'does not name 127.0.0.2, where this peer listens' in message
    assert 'make_certificates' in message and 'verify_name=False' in message
    assert 'zros tls init' not in message and 'ZROS_' not in message
    assert 'does not name 127.0.0.2, where this peer listens' in shell
    assert CLI_FIX in shell and 'ZROS_LISTEN=' in shell
    assert 'make_certificates' not in shell and 'verify_name' not in shell
