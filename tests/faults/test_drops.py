"""How drops are counted per sender and logged: the first at once, then summed up."""

from __future__ import annotations

import logging

import pytest

from zros.runtime import drops


def test_drops_from_one_sender_are_summed_up_once_per_interval(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    now = [1000.0]
    monkeypatch.setattr(drops.time, 'monotonic', lambda: now[0])
    counter = drops.DropCounter('/scan')
    with caplog.at_level(logging.WARNING, logger='zros'):
        counter.add('session:a', lambda: 'session a', 'bad')
        for _ in range(10):
            counter.add('session:a', lambda: 'session a', 'bad')
        counter.add('session:b', lambda: 'session b', 'worse')
        now[0] += drops.SUMMARY_INTERVAL
        counter.add('session:a', lambda: 'session a', 'bad')
        counter.add('session:a', lambda: 'session a', 'bad')
        counter.flush()
    assert [r.getMessage() for r in caplog.records] == [
        'dropped a message on /scan from session a: bad (further drops from it are summed up '
        'every 10 s)',
        'dropped a message on /scan from session b: worse (further drops from it are summed up '
        'every 10 s)',
        'dropped 11 more messages on /scan from session a in the last 10 s (12 in all): bad',
        'dropped 1 more message on /scan from session a before it closed (13 in all): bad',
    ]
    assert counter.counts() == {'session a': 13, 'session b': 1}


def test_senders_beyond_the_limit_are_counted_together(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(drops, 'MAX_SENDERS', 3)
    counter = drops.DropCounter('/scan')
    for number in range(10):
        counter.add(f'gid:{number}', lambda number=number: f'publisher {number}', 'bad')
    assert counter.counts() == {
        'publisher 0': 1,
        'publisher 1': 1,
        'publisher 2': 1,
        drops.OTHERS: 7,
    }
