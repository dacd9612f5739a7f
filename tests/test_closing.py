"""zros.closing: the one ``with`` of zros objects."""

from __future__ import annotations

import pytest

from zros.closing import Closing


class Door(Closing):
    def __init__(self) -> None:
        self.closed = 0

    def close(self) -> None:
        self.closed += 1


def test_a_with_block_closes_it_however_it_ends() -> None:
    with Door() as door:
        assert isinstance(door, Door) and door.closed == 0
    assert door.closed == 1
    with pytest.raises(ValueError, match='inside'), Door() as door:
        raise ValueError('inside')
    assert door.closed == 1


def test_a_class_without_its_own_close_says_so() -> None:
    with pytest.raises(NotImplementedError), Closing():
        pass
