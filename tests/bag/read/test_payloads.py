"""Payloads as offsets into buffers, and the rows ``Bag.columns`` copies fields out of."""

from __future__ import annotations

import numpy as np
import pytest

from zros.bag.read.payloads import Payloads, Rows, gather


def _payloads(buffer: bytes, spans: list[tuple[int, int]]) -> Payloads:
    begins = np.array([b for b, _ in spans], np.int64)
    ends = np.array([e for _, e in spans], np.int64)
    return Payloads(buffer, begins, ends)


def test_payloads_read_like_a_list_of_bytes() -> None:
    payloads = _payloads(b'..abc..de.f', [(2, 5), (7, 9), (10, 11)])
    assert len(payloads) == 3
    assert list(payloads) == [b'abc', b'de', b'f']
    assert payloads[1] == b'de' and payloads[-1] == b'f'
    assert list(payloads[1:]) == [b'de', b'f']
    assert payloads.lengths().tolist() == [3, 2, 1]
    assert list(payloads.select(np.array([True, False, True]))) == [b'abc', b'f']
    assert list(Payloads.joined([b'xy', b'', b'z'])) == [b'xy', b'', b'z']
    assert 'Payloads of 3 messages' in repr(payloads)


@pytest.mark.parametrize(
    ('spans', 'error'),
    [
        ([(0, 4)], 'beyond its buffer'),
        ([(-1, 2)], 'beyond its buffer'),
        ([(2, 1)], 'beyond its buffer'),
    ],
)
def test_payloads_beyond_their_buffer_are_refused(spans: list[tuple[int, int]], error: str) -> None:
    with pytest.raises(ValueError, match=error):
        _payloads(b'abc', spans)
    with pytest.raises(ValueError, match='as many begins as ends'):
        Payloads(b'abc', np.array([0, 1]), np.array([1]))


def test_rows_gather_the_messages_of_one_length_across_buffers() -> None:
    first = _payloads(b'AAAA-bb-CCCC', [(0, 4), (5, 7), (8, 12)])
    second = _payloads(b'xDDDDy', [(1, 5), (5, 6)])
    rows, where = gather([first, second], 4)
    assert len(rows) == 3 and rows.length == 4
    assert where.tolist() == [0, 2, 3]  # positions across the batch, in order
    assert rows.take(0, 4).tobytes() == b'AAAACCCCDDDD'
    assert rows.take(1, 3).tolist() == [list(b'AA'), list(b'CC'), list(b'DD')]
    assert [part.take(0, 4).tobytes() for part in rows.segments()] == [b'AAAACCCC', b'DDDD']
    assert rows.take(2, 2).shape == (3, 0)
    kept = rows.subset(np.array([False, True, True]))
    assert kept.take(0, 4).tobytes() == b'CCCCDDDD'
    none, where = gather([first], 9)
    assert len(none) == 0 and where.tolist() == [] and none.take(0, 9).shape == (0, 9)


def test_taking_beyond_a_row_is_refused() -> None:
    rows = Rows([(np.frombuffer(b'abcdef', np.uint8), np.array([0, 3]))], 3)
    with pytest.raises(ValueError, match='columns 2:4 of rows of 3 bytes'):
        rows.take(2, 4)
    with pytest.raises(ValueError, match='columns 2:1'):
        rows.take(2, 1)
