"""How many clients a gateway serves at once: the bound, what a refused connection is told,
and the log that says so without flooding."""

from __future__ import annotations

import gc
import logging

import pytest

from zros.gateway.common.admission import Admission, check_max_clients
from zros.gateway.common.errors import GatewayError


class _Connection:
    """Anything a gateway admits (a socket, a websockets connection)."""


def test_at_most_the_bound_is_admitted_and_a_place_frees_when_one_leaves() -> None:
    admission = Admission(2)
    first, second, third = _Connection(), _Connection(), _Connection()
    assert admission.enter(first) and admission.enter(second)
    assert not admission.enter(third)
    assert (len(admission), admission.refused) == (2, 1)
    admission.leave(first)
    admission.leave(_Connection())  # never admitted: nothing happens
    assert admission.enter(third) and len(admission) == 2


def test_a_connection_gone_without_leaving_frees_its_place() -> None:
    admission = Admission(1)
    admission.enter(_Connection())  # its handshake failed: nobody calls leave
    gc.collect()
    assert admission.enter(_Connection())


def test_refusals_are_told_and_logged_once_a_period(caplog: pytest.LogCaptureFixture) -> None:
    admission = Admission(1, option='max_clients=')
    keep = _Connection()
    admission.enter(keep)
    with caplog.at_level(logging.WARNING, 'zros.gateway'):
        for _ in range(50):
            assert not admission.enter(_Connection())
    assert admission.refusal() == (
        'too many clients: this server serves at most 1 client at once (max_clients= raises it)'
    )
    lines = [r.getMessage() for r in caplog.records]
    assert lines == [
        'refused 1 connection: the server serves at most 1 client at once (max_clients= raises it)'
    ]
    assert admission.refused == 50


@pytest.mark.parametrize('limit', [0, -3])
def test_a_bound_below_one_is_refused(limit: int) -> None:
    with pytest.raises(GatewayError, match=f'at least 1 client at once, not {limit}'):
        Admission(limit)
    with pytest.raises(GatewayError):
        check_max_clients(limit)
    assert check_max_clients(1) == 1
