"""A frame that changes parent over time (a cup on a table, then in a gripper) is looked up
through the parent it had at the lookup's time, as tf2 does: interpolated while the parent
stays, the last sample held up to the next one under another parent."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from zros.tf import Buffer, ConnectivityException, ExtrapolationException, trajectory
from zros.tf.edge_tree import MAX_PARENTS

S = 10**9


def at(x: float) -> tuple[float, float, float, float, float, float, float]:
    return (x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def x_of(buffer: Buffer, target: str, source: str, stamp: int) -> float:
    return float(buffer.lookup_transform(target, source, stamp).transform.translation.x)


def grasp(buffer: Buffer) -> None:
    """map: table at x=10 (static), gripper at x=100+t; the cup 1 m along the table at 1 s and
    2 s, then 0.5 m along the gripper at 3 s and 4 s."""
    buffer.add('map', 'table', 0, at(10.0), 'world', static=True)
    for second in (1, 2, 3, 4):
        buffer.add('map', 'gripper', second * S, at(100.0 + second), 'arm')
    buffer.add('table', 'cup', 1 * S, at(1.0), 'vision')
    buffer.add('table', 'cup', 2 * S, at(2.0), 'vision')
    buffer.add('gripper', 'cup', 3 * S, at(0.5), 'arm')
    buffer.add('gripper', 'cup', 4 * S, at(0.5), 'arm')


@pytest.mark.parametrize('cache_time', [10.0, None])
def test_a_cup_grasped_from_a_table_is_found_through_its_parent_at_each_time(
    cache_time: float | None,
) -> None:
    buffer = Buffer(cache_time=cache_time)
    grasp(buffer)
    assert x_of(buffer, 'map', 'cup', 1 * S) == pytest.approx(11.0)
    assert x_of(buffer, 'map', 'cup', S + S // 2) == pytest.approx(11.5)  # on the table
    # between the last sample on the table and the first in the gripper, the table's holds
    # (tf2 does not interpolate between two parents)
    assert x_of(buffer, 'map', 'cup', 2 * S + S // 2) == pytest.approx(12.0)
    assert x_of(buffer, 'map', 'cup', 3 * S + S // 2) == pytest.approx(104.0)  # in the gripper
    latest = buffer.lookup_transform('map', 'cup', 0)
    assert latest.header.stamp.sec == 4 and latest.transform.translation.x == pytest.approx(104.5)
    assert buffer.all_frames_as_string().count('Frame cup exists with parent gripper.') == 1
    assert x_of(buffer, 'table', 'cup', 1 * S) == pytest.approx(1.0)
    assert x_of(buffer, 'gripper', 'cup', 4 * S) == pytest.approx(0.5)
    with pytest.raises(ExtrapolationException, match='into the past'):
        buffer.lookup_transform('map', 'cup', S // 2)
    with pytest.raises(ExtrapolationException, match='into the future'):
        buffer.lookup_transform('map', 'cup', 5 * S)


def test_a_parent_taken_again_is_not_interpolated_across_the_other() -> None:
    """Samples under A at 1 and 4 s with one under B at 3 s between: at 2.5 s the frame hangs
    from A, held at its 1 s sample, not drawn towards the 4 s one."""
    buffer = Buffer()
    buffer.add('root', 'a', 0, at(0.0), 'fixed', static=True)
    buffer.add('root', 'b', 0, at(50.0), 'fixed', static=True)
    buffer.add('a', 'thing', 1 * S, at(1.0), 'x')
    buffer.add('a', 'thing', 4 * S, at(4.0), 'x')
    buffer.add('b', 'thing', 3 * S, at(3.0), 'y')
    assert x_of(buffer, 'root', 'thing', 2 * S) == pytest.approx(1.0)
    assert x_of(buffer, 'root', 'thing', 3 * S) == pytest.approx(53.0)
    assert x_of(buffer, 'root', 'thing', 3 * S + S // 2) == pytest.approx(53.0)
    assert x_of(buffer, 'root', 'thing', 4 * S) == pytest.approx(4.0)
    buffer.add('a', 'thing', 5 * S, at(5.0), 'x')
    assert x_of(buffer, 'root', 'thing', 4 * S + S // 2) == pytest.approx(4.5)


@pytest.mark.parametrize('at_a_time', [7, 1000])
def test_many_stamps_agree_with_single_lookups_across_the_handover(
    monkeypatch: pytest.MonkeyPatch, at_a_time: int
) -> None:
    """Stamps go a few at a time under the lock (a listener is not held up): any batch size
    gives the single lookups' answers."""
    from zros.tf import buffer as buffer_module

    monkeypatch.setattr(buffer_module, 'ONE_BY_ONE', at_a_time)
    buffer = Buffer()
    grasp(buffer)
    stamps = np.arange(0, 5 * S, S // 10, dtype=np.int64)
    translations, rotations = buffer.lookup_transforms('map', 'cup', stamps)
    for stamp, row, rotation in zip(stamps.tolist(), translations, rotations, strict=True):
        if S <= stamp <= 4 * S:
            assert row[0] == pytest.approx(x_of(buffer, 'map', 'cup', stamp))
            assert rotation.tolist() == [0.0, 0.0, 0.0, 1.0]
        else:
            assert np.isnan(row).all()
    with pytest.raises(ExtrapolationException, match=r'times\[0\]'):
        buffer.lookup_transforms('map', 'cup', stamps, strict=True)


def test_the_stamps_of_a_chain_through_a_handover_are_both_parents() -> None:
    buffer = Buffer()
    grasp(buffer)
    assert (buffer.stamps('map', 'cup') // S).tolist() == [1, 2, 3, 4]
    columns = trajectory(buffer, 'map', 'cup')
    assert columns['x'].tolist() == pytest.approx([11.0, 12.0, 103.5, 104.5])


def test_a_recording_of_a_handover_reads_as_live(tmp_path: Path) -> None:
    from tests.bag.makebags import make_db3
    from zros.cdr import encode, new_message

    def message(parent: str, child: str, second: int, x: float) -> bytes:
        stamped = {
            'header': {'stamp': {'sec': second}, 'frame_id': parent},
            'child_frame_id': child,
            'transform': {'translation': {'x': x}, 'rotation': {'w': 1.0}},
        }
        return encode(new_message('tf2_msgs/msg/TFMessage', transforms=[stamped]))

    rows = [(1, 0, message('map', 'table', 0, 10.0))]
    rows += [(0, n * S, message('map', 'gripper', n, 100.0 + n)) for n in (1, 2, 3, 4)]
    rows += [(0, n * S, message('table', 'cup', n, float(n))) for n in (1, 2)]
    rows += [(0, n * S, message('gripper', 'cup', n, 0.5)) for n in (3, 4)]
    topics = [('/tf', 'tf2_msgs/msg/TFMessage'), ('/tf_static', 'tf2_msgs/msg/TFMessage')]
    path = make_db3(tmp_path / 'handover.db3', topics, rows)
    columns = trajectory(path, 'map', 'cup')
    assert (columns['t'] // S).tolist() == [1, 2, 3, 4]
    assert columns['x'].tolist() == pytest.approx([11.0, 12.0, 103.5, 104.5])


def test_the_change_of_parent_is_told_once(caplog: pytest.LogCaptureFixture) -> None:
    buffer = Buffer()
    with caplog.at_level(logging.INFO, 'zros.tf'):
        for second in range(1, 20):  # two publishers fighting over one frame
            assert buffer.add('odom', 'base', 2 * second * S, at(1.0), 'odometry')
            assert buffer.add('map', 'base', (2 * second + 1) * S, at(2.0), 'slam')
    told = [r.getMessage() for r in caplog.records if r.name == 'zros.tf']
    assert told == [
        'frame "base" takes the parent "map" (from authority "slam"); it had "odom": lookups '
        'use the parent it had at their time, as tf2 does'
    ]
    assert buffer.rejections.counts == {}


def test_a_new_parent_below_the_frame_is_a_loop() -> None:
    buffer = Buffer()
    buffer.add('map', 'base', 1 * S, at(1.0), 'odometry')
    buffer.add('base', 'arm', 1 * S, at(1.0), 'arm')
    assert not buffer.add('arm', 'base', 2 * S, at(1.0), 'confused')
    assert buffer.rejections.counts['TF_LOOP'] == 1
    assert x_of(buffer, 'map', 'arm', 1 * S) == pytest.approx(2.0)


def test_a_static_frame_given_a_new_parent_takes_it() -> None:
    """tf2's static cache holds one transform, its parent included."""
    buffer = Buffer()
    buffer.add('base', 'camera', 0, at(1.0), 'urdf', static=True)
    buffer.add('head', 'camera', 0, at(2.0), 'urdf', static=True)
    assert buffer.all_frames_as_string() == 'Frame camera exists with parent head.\n'
    assert x_of(buffer, 'head', 'camera', 7 * S) == pytest.approx(2.0)


def test_old_parents_leave_with_the_window_and_are_bounded() -> None:
    """A live buffer keeps a frame's old parents only while their data is in the window, and at
    most MAX_PARENTS of them: a flood of new parents cannot grow it."""
    buffer = Buffer(cache_time=1.0)
    buffer.add('odom', 'base', 1 * S, at(1.0), 'odometry')
    buffer.add('map', 'base', 3 * S, at(2.0), 'slam')  # odom's data is 2 s old: it goes
    assert x_of(buffer, 'map', 'base', 3 * S) == pytest.approx(2.0)
    with pytest.raises(ConnectivityException):  # odom is known still, alone
        buffer.lookup_transform('odom', 'base', 1 * S)
    for number in range(1000):
        buffer.add(f'holder{number}', 'base', 4 * S + number, at(3.0), 'juggler')
    assert x_of(buffer, 'holder999', 'base', 4 * S + 999) == pytest.approx(3.0)
    assert x_of(buffer, 'holder990', 'base', 4 * S + 990) == pytest.approx(3.0)
    with pytest.raises(ConnectivityException):
        buffer.lookup_transform('holder0', 'base', 4 * S)  # past the newest MAX_PARENTS
    assert MAX_PARENTS < 990


def test_clear_forgets_old_parents() -> None:
    buffer = Buffer()
    grasp(buffer)
    buffer.clear()
    buffer.add('table', 'cup', 10 * S, at(1.0), 'vision')
    assert x_of(buffer, 'map', 'cup', 10 * S) == pytest.approx(11.0)
    assert buffer.all_frames_as_string().count('cup exists with parent table') == 1


def test_a_flood_of_new_parents_for_one_frame_is_bounded() -> None:
    """Each new parent is a new frame name; a live buffer stops taking them where its frames
    would (a child and a parent each), as it does for new frames."""
    from zros.tf.edge_tree import MAX_FRAMES

    buffer = Buffer()
    for number in range(2 * MAX_FRAMES + 100):
        buffer.add(f'p{number}', 'base', S + number, at(1.0), 'flood')
    assert len(buffer.frames()) == 2 * MAX_FRAMES
    assert buffer.rejections.counts['TF_TOO_MANY_FRAMES'] == 101
    newest = 2 * MAX_FRAMES - 2  # the last parent taken
    assert x_of(buffer, f'p{newest}', 'base', S + newest) == pytest.approx(1.0)


def test_frames_joined_at_no_stamp_are_a_connectivity_error() -> None:
    """Through a frame that changed parent, stamps where the frames are not joined are NaN;
    when they are joined at none of them, the error says so, as a single lookup does."""
    buffer = Buffer()
    buffer.add('a', 'thing', 1 * S, at(1.0), 'x')
    buffer.add('b', 'thing', 3 * S, at(2.0), 'y')
    buffer.add('elsewhere', 'lonely', 1 * S, at(0.0), 'z')
    translations, _ = buffer.lookup_transforms('a', 'thing', np.array([S, 3 * S]))
    assert translations[0, 0] == pytest.approx(1.0) and np.isnan(translations[1]).all()
    with pytest.raises(ConnectivityException, match='not part of the same tree'):
        buffer.lookup_transforms('elsewhere', 'thing', np.array([S, 3 * S]))
    with pytest.raises(ConnectivityException, match=r'times\[0\]'):
        buffer.lookup_transforms('elsewhere', 'thing', np.array([S]), strict=True)


def test_a_frame_with_no_transform_under_any_parent_is_refused() -> None:
    from zros.tf.cache import EdgeCache
    from zros.tf.parents import edge_at

    empty = {'a': EdgeCache('a', static=False, max_age=None)}
    with pytest.raises(ValueError, match='no transforms under any parent'):
        edge_at(empty, S)
