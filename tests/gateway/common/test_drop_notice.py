"""DropNotices: at most one notice a second per client, telling the drops since the last one."""

from __future__ import annotations

from zros.gateway.common.drop_notice import NOTICE_PERIOD, DropNotices


class _Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_the_first_drops_are_told_at_once_then_at_most_once_a_period() -> None:
    clock = _Clock()
    notices = DropNotices(clock=clock)
    assert notices.due(3) == 3
    clock.now += NOTICE_PERIOD / 2
    assert notices.due(10) is None  # too soon: counted for the next notice
    assert notices.told == 3
    clock.now += NOTICE_PERIOD / 2
    assert notices.due(12) == 9  # the drops since the last notice
    assert notices.told == 12


def test_no_new_drops_is_no_notice_and_keeps_the_next_one_due() -> None:
    clock = _Clock()
    notices = DropNotices(period=2.0, clock=clock)
    assert notices.due(0) is None
    assert notices.due(1) == 1
    clock.now += 5.0
    assert notices.due(1) is None  # nothing new to tell
    assert notices.due(2) == 1  # new drops are told at once: no notice went meanwhile
