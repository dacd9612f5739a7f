"""SampleQueue: a subscription's bounded queue of raw samples (keep-last, or keep-all within
a count and a byte bound)."""

from __future__ import annotations

from zros.runtime.sample_queue import SAMPLE_OVERHEAD, SampleQueue


def test_a_keep_all_queue_given_a_batch_past_its_bound_keeps_what_fits() -> None:
    class FakeSample:
        payload = b'x' * 10

    queue = SampleQueue(None, max_count=3, max_bytes=10**6)
    samples = [FakeSample() for _ in range(5)]
    assert queue.put(samples) == 2
    assert queue.pop() == samples[:3]
    assert (queue.received, queue.overflowed) == (5, 2)
    keep_last = SampleQueue(2, None, None)
    assert keep_last.put(samples) == 0
    assert keep_last.pop() == samples[3:]


def test_a_keep_all_queue_counts_the_bytes_of_whole_and_cut_batches() -> None:
    class FakeSample:
        payload = b'x' * 10

    each = 10 + SAMPLE_OVERHEAD
    queue = SampleQueue(None, max_count=None, max_bytes=3 * each)
    first, second = [FakeSample() for _ in range(2)], [FakeSample() for _ in range(3)]
    assert queue.put(first) == 0 and queue.nbytes == 2 * each  # the whole batch fits
    assert queue.put(second) == 2 and queue.nbytes == 3 * each  # one of three fits
    assert queue.pop(1) == first[:1] and queue.nbytes == 2 * each
    assert queue.put(second[1:]) == 1 and queue.nbytes == 3 * each
    assert queue.pop() == [*first[1:], second[0], second[1]] and queue.nbytes == 0
