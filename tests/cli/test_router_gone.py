"""``zros service call`` and ``action send_goal`` whose router dies while they wait: one line
that says so, a non-zero exit, at once."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from tests.cli.conftest import ZROS, Cli
from tests.support.router_process import CALL_TIMEOUT, FIB, TRIGGER, Rig, rig_running

pytestmark = pytest.mark.skipif(ZROS is None, reason='the zros console script is not installed')


@pytest.fixture
def rig() -> Iterator[Rig]:
    with rig_running() as running:
        yield running


@pytest.mark.parametrize(
    'command',
    [
        ('service', 'call', '/slow', TRIGGER, '--timeout', str(CALL_TIMEOUT)),
        ('action', 'send_goal', '/fib', FIB, '{order: 3}'),
    ],
    ids=['service call', 'action send_goal'],
)
def test_the_router_dying_ends_the_command_at_once(rig: Rig, command: tuple[str, ...]) -> None:
    cli = Cli(rig.router.endpoint)
    running = cli.start(*command)
    try:
        assert rig.holding.wait(CALL_TIMEOUT), 'the server never got the request'
        killed = time.monotonic()
        rig.router.kill()
        code, _ = running.finish()
        waited = time.monotonic() - killed
    finally:
        if running.process.poll() is None:
            running.process.kill()
    errors = running.errors.text().splitlines()
    assert code == 1
    assert len(errors) == 1, errors  # the error alone: not the transport's warning too
    assert errors[0].startswith('zros: error: ')
    assert f'the link to the router at {rig.router.endpoint} was lost' in errors[0]
    assert waited < CALL_TIMEOUT / 3, f'{waited:.1f} s from the kill to the exit'
