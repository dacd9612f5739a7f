"""The Origin check both gateways apply to a browser's WebSocket upgrade."""

from __future__ import annotations

import logging

import pytest

from zros.gateway.common.origins import FOXGLOVE_APP, OriginPolicy


@pytest.mark.parametrize(
    'origin',
    [
        None,
        'http://localhost:5173',
        'http://127.0.0.1',
        'https://127.8.9.10:8443',
        'http://[::1]:3000',
    ],
)
def test_programs_and_pages_of_this_machine_are_accepted(origin: str | None) -> None:
    assert OriginPolicy().accepts(origin)


@pytest.mark.parametrize(
    'origin',
    ['https://evil.example', 'http://localhost.evil.example', 'null', 'http://10.0.0.5', ''],
)
def test_other_pages_are_refused(origin: str) -> None:
    assert not OriginPolicy().accepts(origin)


def test_listed_origins_are_accepted_as_browsers_spell_them() -> None:
    policy = OriginPolicy([FOXGLOVE_APP, 'HTTPS://Viewer.Example:8443/'])
    assert policy.accepts('https://app.foxglove.dev')
    assert policy.accepts('https://viewer.example:8443')
    assert not policy.accepts('https://viewer.example')  # another port is another origin
    assert not policy.accepts('http://app.foxglove.dev')  # and so is another scheme


def test_any_origin_says_so(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger='zros.gateway'):
        policy = OriginPolicy(['*'])
    assert policy.accepts('https://evil.example')
    assert 'every web page may open this gateway (--allow-origin *)' in caplog.text


def test_a_refusal_logs_the_origin_and_the_option(caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.WARNING, logger='zros.gateway'):
        reason = OriginPolicy(option='allow_origins=').refuse('https://evil.example')
    assert 'https://evil.example' in reason
    assert caplog.messages == [
        'refused a WebSocket upgrade from a page of https://evil.example; '
        'to allow it: allow_origins= https://evil.example'
    ]
