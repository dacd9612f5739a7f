"""The synchronizers' matching rules (rclpy's message_filters), worked out by hand."""

from __future__ import annotations

import pytest

from zros.timesync import ApproximatePolicy, ExactPolicy, header_stamp


def test_exact_emits_common_stamps_oldest_first_and_a_stamp_replaces() -> None:
    policy: ExactPolicy[str] = ExactPolicy(2, 10)
    assert policy.add(0, 1, 'a1') == []
    assert policy.add(0, 2, 'a2') == []
    assert policy.add(0, 2, 'a2bis') == []  # the same stamp again: the newer replaces
    assert policy.add(1, 3, 'b3') == []
    assert policy.add(1, 2, 'b2') == [('a2bis', 'b2')]
    assert policy.add(1, 1, 'b1') == [('a1', 'b1')]
    assert policy.queues == [{}, {3: 'b3'}]


def test_exact_queue_size_drops_the_oldest_stamp() -> None:
    policy: ExactPolicy[str] = ExactPolicy(2, 2)
    for stamp in (1, 2, 3):
        policy.add(0, stamp, f'a{stamp}')
    assert list(policy.queues[0]) == [2, 3]
    assert policy.add(1, 1, 'b1') == []


def test_approximate_takes_the_closest_set_within_slop() -> None:
    policy: ApproximatePolicy[str] = ApproximatePolicy(3, 10, 10)
    assert policy.add(0, 100, 'a100') == []
    assert policy.add(1, 104, 'b104') == []  # the third input has nothing yet
    assert policy.add(1, 97, 'b97') == []
    assert policy.add(2, 95, 'c95') == [('a100', 'b97', 'c95')]  # b97 is closer to c95 than b104
    assert policy.add(2, 114, 'c114') == []  # b104 is 10 away but a100 is gone
    assert policy.add(0, 109, 'a109') == []  # a109, b104, c114 span 10: not less than slop
    assert policy.add(1, 112, 'b112') == [('a109', 'b112', 'c114')]
    assert policy.queues == [{}, {104: 'b104'}, {}]


def test_approximate_span_must_be_less_than_slop() -> None:
    policy: ApproximatePolicy[str] = ApproximatePolicy(2, 10, 10)
    assert policy.add(0, 200, 'a') == []
    assert policy.add(1, 210, 'b') == []  # 10 apart: within the search, but not less than slop
    assert policy.add(1, 209, 'b2') == [('a', 'b2')]
    assert policy.queues == [{}, {210: 'b'}]


def test_a_dropped_arrival_matches_nothing() -> None:
    policy: ApproximatePolicy[str] = ApproximatePolicy(2, 1, 10)
    policy.add(0, 131, 'a131')
    assert policy.add(0, 125, 'a125') == []  # older than the one it would evict: gone at once
    assert policy.add(1, 126, 'b126') == [('a131', 'b126')]


@pytest.mark.parametrize(
    ('make', 'match'),
    [
        (lambda: ExactPolicy(0, 1), 'at least one input'),
        (lambda: ExactPolicy(2, 0), 'queue_size must be at least 1'),
        (lambda: ApproximatePolicy(2, 1, -1), 'slop must not be negative'),
    ],
)
def test_bad_settings(make: object, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        make()  # type: ignore[operator]


def test_header_stamp_reads_messages_and_times() -> None:
    from zros.cdr import new_message

    message = new_message('std_msgs/msg/Header')
    message.stamp.sec, message.stamp.nanosec = 3, 7
    stamped = new_message('geometry_msgs/msg/PointStamped', header=message)
    assert header_stamp(stamped) == 3_000_000_007
    assert header_stamp(new_message('std_msgs/msg/Float64')) is None


@pytest.mark.parametrize(('first', 'second'), [(95, 105), (105, 95)])
def test_a_tie_goes_to_the_one_queued_first(first: int, second: int) -> None:
    """Both are 5 from the arrival: rclpy sorts candidates stably, in queue order."""
    policy: ApproximatePolicy[str] = ApproximatePolicy(2, 10, 10)
    policy.add(1, first, f'b{first}')
    policy.add(1, second, f'b{second}')
    assert policy.add(0, 100, 'a100') == [('a100', f'b{first}')]


def test_exact_with_out_of_order_stamps() -> None:
    policy: ExactPolicy[str] = ExactPolicy(2, 10)
    for stamp in (30, 10, 20):
        policy.add(0, stamp, f'a{stamp}')
    assert policy.add(1, 20, 'b20') == [('a20', 'b20')]
    assert policy.add(1, 10, 'b10') == [('a10', 'b10')]
    assert policy.queues == [{30: 'a30'}, {}]
