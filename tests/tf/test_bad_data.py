"""Bad transforms are refused with tf2's wording, logged once per sender, and never stop the
buffer; a live buffer's memory stays within its window."""

from __future__ import annotations

import logging
import math

import pytest

from zros.tf import Buffer, LookupException

GOOD = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def warnings(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == 'zros.tf']


@pytest.mark.parametrize(
    ('parent', 'child', 'pose', 'told'),
    [
        ('a', 'a', GOOD, ('TF_SELF_TRANSFORM',
         'TF_SELF_TRANSFORM: Ignoring transform from authority "pub1" with frame_id and '
         'child_frame_id "a" because they are the same')),
        ('a', 'b', (math.nan, 0, 0, 0, 0, 0, 1), ('TF_NAN_INPUT',
         'TF_NAN_INPUT: Ignoring transform for child_frame_id "b" from authority "pub1" '
         'because of a nan value in the transform (nan 0.000000')),
        ('a', 'b', (0, 0, 0, 0, 0, 0, math.inf), ('TF_NAN_INPUT', 'TF_NAN_INPUT')),
        ('a', 'b', (0, 0, 0, 0, 0, 0, 0.9), ('TF_DENORMALIZED_QUATERNION',
         'TF_DENORMALIZED_QUATERNION: Ignoring transform for child_frame_id "b" from authority '
         '"pub1" because of an invalid quaternion in the transform (0.000000 0.000000 0.000000 '
         '0.900000)')),
        ('a', '', GOOD, ('TF_NO_CHILD_FRAME_ID', 'because child_frame_id not set')),
        ('', 'b', GOOD, ('TF_NO_FRAME_ID', 'because frame_id not set')),
    ],
)  # fmt: skip
def test_a_bad_transform_is_dropped_and_told_once_per_sender(
    caplog: pytest.LogCaptureFixture,
    parent: str,
    child: str,
    pose: tuple[float, ...],
    told: tuple[str, str],
) -> None:
    code, wording = told
    buffer = Buffer()
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        for stamp in range(1, 50):
            assert not buffer.add(parent, child, stamp, pose, 'pub1')  # type: ignore[arg-type]
        assert not buffer.add(parent, child, 99, pose, 'pub2')  # type: ignore[arg-type]
    lines = warnings(caplog)
    assert len(lines) == 2, lines  # once per sender
    assert lines[0].startswith(code) and wording in lines[0]
    assert '"pub2"' in lines[1]
    assert buffer.rejections.counts[code] == 50
    assert buffer.frames() == set()


def test_a_slightly_denormalised_quaternion_is_normalised_not_refused() -> None:
    """tf2's tolerance: a squared length within 0.01 of 1, as hand-written 0.7071 gives."""
    buffer = Buffer()
    assert buffer.add('a', 'b', 1, (0, 0, 0, 0, 0, 0, 1.000004), 'pub')
    assert buffer.lookup_transform('a', 'b', 1).transform.rotation.w == 1.0
    assert buffer.add('a', 'c', 1, (0, 0, 0, 0, 0, 0.7071, 0.7071), 'pub')
    rotation = buffer.lookup_transform('a', 'c', 1).transform.rotation
    assert rotation.z == pytest.approx(math.sqrt(0.5), abs=1e-15) == rotation.w
    assert buffer.add('a', 'd', 1, (0, 0, 0, 0, 0, 0, 1.004), 'pub')  # 1.008: within
    assert not buffer.add('a', 'e', 1, (0, 0, 0, 0, 0, 0, 1.006), 'pub')  # 1.012: beyond


def test_a_loop_is_refused_and_the_tree_keeps_working(caplog: pytest.LogCaptureFixture) -> None:
    buffer = Buffer()
    assert buffer.add('a', 'b', 1, GOOD, 'pub')
    assert buffer.add('b', 'c', 1, GOOD, 'pub')
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        assert not buffer.add('c', 'a', 1, GOOD, 'looper')  # a -> b -> c -> a
        assert not buffer.add('c', 'a', 2, GOOD, 'looper')
        assert not buffer.add('a', 'a', 2, GOOD, 'looper')
    told = warnings(caplog)
    assert told[0] == (
        'TF_LOOP: Ignoring transform for child_frame_id "a" from authority "looper" with '
        'frame_id "c": it would close a loop (a -> c -> b -> a)'
    )
    assert len(told) == 2  # the loop once, the self transform once
    assert buffer.rejections.counts['TF_LOOP'] == 2
    assert buffer.lookup_transform('a', 'c', 1).transform.translation.x == 2.0


def test_repeated_and_old_data(caplog: pytest.LogCaptureFixture) -> None:
    buffer = Buffer(cache_time=10.0)
    second = 10**9
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        assert buffer.add('odom', 'base', 100 * second, GOOD, 'odometry')
        assert not buffer.add('odom', 'base', 100 * second, (2, 0, 0, 0, 0, 0, 1), 'odometry')
        assert not buffer.add('odom', 'base', 80 * second, GOOD, 'odometry')
        assert buffer.add('odom', 'base', 95 * second, GOOD, 'odometry')  # late but in the window
    told = warnings(caplog)
    assert told[0] == (
        'TF_REPEATED_DATA ignoring data with redundant timestamp for frame base (parent odom) '
        'at time 100.000000000 according to authority odometry'
    )
    assert told[1].startswith(
        'TF_OLD_DATA ignoring data from the past for frame base at time 80.000000000 according '
        'to authority odometry'
    )
    assert buffer.lookup_transform('odom', 'base', 100 * second).transform.translation.x == 1.0
    assert buffer.rejections.counts == {'TF_REPEATED_DATA': 1, 'TF_OLD_DATA': 1}


def test_out_of_order_transforms_are_sorted_in() -> None:
    buffer = Buffer()
    for stamp in (30, 10, 20, 50, 40):
        assert buffer.add('a', 'b', stamp, (stamp, 0, 0, 0, 0, 0, 1), 'pub')
    for stamp in range(10, 51):
        assert buffer.lookup_transform('a', 'b', stamp).transform.translation.x == stamp


def test_memory_is_bounded_by_the_cache_time() -> None:
    buffer = Buffer(cache_time=1.0)
    for i in range(20_000):  # 20 s at 1 kHz
        buffer.add('odom', 'base', i * 10**6, (i, 0, 0, 0, 0, 0, 1), 'odometry')
    (edge,) = buffer.edges()
    assert edge.length == 1001  # 1 s before the newest, both ends included
    assert edge.oldest == 18_999 * 10**6
    assert edge.received == 20_000
    held = buffer._tree.edges['base']
    assert len(held._stamps) <= 4096  # the room did not grow with what went through


def test_a_live_buffer_holds_a_bounded_number_of_frames_and_rows(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.tf import edge_tree as module

    monkeypatch.setattr(module, 'MAX_FRAMES', 5)
    monkeypatch.setattr(module, 'MAX_EDGE_LENGTH', 100)
    buffer = Buffer(cache_time=3600.0)
    with caplog.at_level(logging.WARNING, 'zros.tf'):
        for i in range(8):
            buffer.add('root', f'flood{i}', 1, GOOD, 'flooder')
        buffer.add('root', 'late', 1, GOOD, 'other')
    assert len(buffer.edges()) == 5
    assert buffer.rejections.counts['TF_TOO_MANY_FRAMES'] == 4
    told = [line for line in warnings(caplog) if 'TF_TOO_MANY_FRAMES' in line]
    assert len(told) == 2 and '"other"' in told[1]  # once per sender, not once per new name
    for stamp in range(2, 1000):  # 1 ns apart: all inside the hour the buffer keeps
        assert buffer.add('root', 'flood0', stamp, GOOD, 'flooder')
    edge = next(e for e in buffer.edges() if e.frame == 'flood0')
    assert edge.length == 100 and edge.newest == 999


def test_a_static_frame_that_starts_moving_takes_the_moving_values() -> None:
    """tf2 replaces a frame's cache when its kind changes: a frame sent static, then moving,
    follows the moving transforms (zros kept the static value for every time)."""
    buffer = Buffer()
    second = 10**9
    assert buffer.add('base', 'arm', 1 * second, (3.0, 0, 0, 0, 0, 0, 1), 'pub', static=True)
    assert buffer.add('base', 'arm', 5 * second, (2.0, 0, 0, 0, 0, 0, 1), 'pub')
    assert buffer.add('base', 'arm', 6 * second, (3.0, 0, 0, 0, 0, 0, 1), 'pub')
    assert buffer.lookup_transform('base', 'arm', 5 * second).transform.translation.x == 2.0
    halfway = buffer.lookup_transform('base', 'arm', 5 * second + second // 2)
    assert halfway.transform.translation.x == pytest.approx(2.5)
    # and static again: one value for every time
    assert buffer.add('base', 'arm', 7 * second, (9.0, 0, 0, 0, 0, 0, 1), 'pub', static=True)
    assert buffer.lookup_transform('base', 'arm', second).transform.translation.x == 9.0


def test_a_chain_deeper_than_tf2_allows_is_named_so() -> None:
    """tf2 refuses graphs deeper than 1000 frames; the error said two trees were not joined and
    named a wrong root."""
    buffer = Buffer()
    for i in range(1500):
        assert buffer.add(f'l{i}', f'l{i + 1}', 0, GOOD, 'deep', static=True)
    with pytest.raises(LookupException, match='deeper than 1000 frames'):
        buffer.lookup_transform('l0', 'l1500', 0)
    with pytest.raises(LookupException, match='deeper than 1000 frames'):
        buffer.lookup_transform('l1500', 'l0', 0)
    assert buffer.lookup_transform('l0', 'l10', 0).transform.translation.x == pytest.approx(10.0)
