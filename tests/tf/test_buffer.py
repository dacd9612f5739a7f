"""The buffer's answers against an independent implementation (pytransform3d) and matrices
composed by hand, to 1e-9; tf2's time-0 rule; lookups through a fixed frame; the errors."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from pytransform3d.transform_manager import (
    NumpyTimeseriesTransform,
    StaticTransform,
    TemporalTransformManager,
)

from tests.tf.trees import matrix, random_tree
from zros import Time, ZrosError
from zros.cdr import Message
from zros.tf import (
    Buffer,
    ConnectivityException,
    ExtrapolationException,
    InvalidArgumentException,
    LookupException,
    TransformException,
)

TOL = 1e-9


def as_matrix(t: Message) -> np.ndarray:
    tr, q = t.transform.translation, t.transform.rotation
    return matrix(np.array([tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w]))


def frames_of(tree) -> list[str]:
    return sorted({*tree.edges, *(e.parent for e in tree.edges.values())})


@pytest.mark.parametrize('depth', range(1, 9))
def test_random_trees_match_pytransform3d_at_sample_stamps(depth: int) -> None:
    rng = np.random.default_rng(depth)
    grid = np.sort(rng.choice(np.arange(10**12, 10**12 + 10**10, 10**6), 8, replace=False))
    tree = random_tree(rng, depth, grid=grid.astype(np.int64))
    buffer = tree.buffer()
    manager = TemporalTransformManager()
    for edge in tree.edges.values():
        pqs = np.c_[edge.poses[:, :3], edge.poses[:, 6], edge.poses[:, 3:6]]
        if edge.static:
            manager.add_transform(edge.child, edge.parent, StaticTransform(matrix(edge.poses[0])))
        else:
            manager.add_transform(
                edge.child, edge.parent, NumpyTimeseriesTransform(edge.stamps.astype(float), pqs)
            )
    frames = frames_of(tree)
    for _ in range(40):
        target, source = rng.choice(frames, 2)
        stamp = int(rng.choice(grid))
        ours = as_matrix(buffer.lookup_transform(target, source, stamp))
        theirs = manager.get_transform_at_time(source, target, float(stamp))
        np.testing.assert_allclose(ours, theirs, atol=TOL)


@pytest.mark.parametrize('depth', range(1, 9))
def test_random_trees_at_random_stamps_match_matrices_composed_by_hand(depth: int) -> None:
    rng = np.random.default_rng(100 + depth)
    tree = random_tree(rng, depth)
    buffer = tree.buffer()
    moving = [e for e in tree.edges.values() if not e.static]
    low = max((int(e.stamps[0]) for e in moving), default=0)
    high = min((int(e.stamps[-1]) for e in moving), default=10**9)
    frames = frames_of(tree)
    checked = 0
    for _ in range(60):
        target, source = rng.choice(frames, 2)
        stamp = int(rng.integers(low, high + 1)) if low <= high else 0
        try:
            got = buffer.lookup_transform(target, source, stamp)
        except ExtrapolationException:
            assert low > high  # only when the edges share no instant
            continue
        if stamp == 0:
            stamp = Time.from_msg(got.header.stamp).nanoseconds
        np.testing.assert_allclose(as_matrix(got), tree.matrix(target, source, stamp), atol=TOL)
        checked += 1
    assert checked or low > high


def test_interpolation_midpoint_is_half_the_translation_and_half_the_angle() -> None:
    buffer = Buffer()
    buffer.add('odom', 'base', 1_000, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0), 'test')
    s = math.sin(math.pi / 4)
    buffer.add('odom', 'base', 3_000, (2.0, 4.0, 6.0, 0.0, 0.0, s, s), 'test')  # 90 deg about z
    t = buffer.lookup_transform('odom', 'base', 2_000)
    tr, q = t.transform.translation, t.transform.rotation
    assert (tr.x, tr.y, tr.z) == pytest.approx((1.0, 2.0, 3.0), abs=TOL)
    half = math.pi / 8  # 45 degrees: half angle pi/8
    assert (q.x, q.y, q.z, q.w) == pytest.approx((0, 0, math.sin(half), math.cos(half)), abs=TOL)
    quarter = buffer.lookup_transform('odom', 'base', 1_500).transform.rotation
    assert quarter.z == pytest.approx(math.sin(math.pi / 16), abs=TOL)


def test_slerp_takes_the_shorter_arc() -> None:
    buffer = Buffer()
    s = math.sin(math.pi / 4)
    buffer.add('a', 'b', 0 + 10, (0, 0, 0, 0.0, 0.0, s, s), 'test')
    buffer.add('a', 'b', 20, (0, 0, 0, 0.0, 0.0, -s, -s), 'test')  # the same rotation, negated
    q = buffer.lookup_transform('a', 'b', 15).transform.rotation
    assert abs(q.z) == pytest.approx(s, abs=TOL) and abs(q.w) == pytest.approx(s, abs=TOL)


def test_time_zero_is_the_latest_instant_the_whole_chain_knows() -> None:
    buffer = Buffer()
    identity = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    for stamp in (100, 200, 300):
        buffer.add('map', 'odom', stamp, (stamp / 100, 0, 0, 0, 0, 0, 1), 'amcl')
    for stamp in (150, 250):
        buffer.add('odom', 'base', stamp, (0, stamp / 50, 0, 0, 0, 0, 1), 'odom')
    buffer.add('base', 'laser', 0, (0, 0, 1, 0, 0, 0, 1), 'static', static=True)
    t = buffer.lookup_transform('map', 'laser', 0)
    assert Time.from_msg(t.header.stamp).nanoseconds == 250
    tr = t.transform.translation
    assert (tr.x, tr.y, tr.z) == pytest.approx((2.5, 5.0, 1.0), abs=TOL)
    assert buffer.lookup_transform('map', 'laser', Time(250)) == t
    # a chain of static edges only answers at time 0 with stamp 0
    buffer.add('laser', 'lens', 0, identity, 'static', static=True)
    assert buffer.lookup_transform('base', 'lens', 0).header.stamp.sec == 0
    # static transforms hold at every time
    assert buffer.lookup_transform('base', 'lens', 10**18).transform.translation.z == 1.0


def test_lookup_transform_full_through_a_fixed_frame_the_robot_moves_in() -> None:
    buffer = Buffer()
    s, c = math.sin(0.3), math.cos(0.3)
    for i, stamp in enumerate((1_000, 2_000, 3_000)):  # the robot drives and turns in odom
        angle = 0.4 * i
        buffer.add(
            'odom', 'base', stamp,
            (1.5 * i, 0.5 * i, 0.0, 0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)), 'odom',
        )  # fmt: skip
    buffer.add('base', 'camera', 0, (0.2, 0.0, 0.5, s, 0.0, 0.0, c), 'static', static=True)
    # where was the camera at t=1000, seen from the camera at t=3000?
    t = buffer.lookup_transform_full('camera', 3_000, 'camera', 1_000, 'odom')
    odom_cam_then = as_matrix(buffer.lookup_transform('odom', 'camera', 1_000))
    odom_cam_now = as_matrix(buffer.lookup_transform('odom', 'camera', 3_000))
    expected = np.linalg.inv(odom_cam_now) @ odom_cam_then
    np.testing.assert_allclose(as_matrix(t), expected, atol=TOL)
    assert not np.allclose(expected, np.eye(4))  # the frame moved: not the identity
    assert Time.from_msg(t.header.stamp).nanoseconds == 3_000
    assert t.header.frame_id == 'camera' and t.child_frame_id == 'camera'
    assert buffer.can_transform_full('camera', 3_000, 'camera', 1_000, 'odom')
    assert not buffer.can_transform_full('camera', 4_000, 'camera', 1_000, 'odom')


def test_times_are_nanoseconds_zros_time_or_a_stamp_message() -> None:
    buffer = Buffer()
    buffer.add('a', 'b', 5 * 10**9, (1, 0, 0, 0, 0, 0, 1), 'test')
    by_int = buffer.lookup_transform('a', 'b', 5 * 10**9)
    assert buffer.lookup_transform('a', 'b', Time(5 * 10**9)) == by_int
    assert buffer.lookup_transform('a', 'b', by_int.header.stamp) == by_int
    with pytest.raises(InvalidArgumentException, match=r'zros\.Time\.from_seconds'):
        buffer.lookup_transform('a', 'b', 5.0)  # type: ignore[arg-type]
    with pytest.raises(InvalidArgumentException, match='negative'):
        buffer.lookup_transform('a', 'b', -1)
    with pytest.raises(InvalidArgumentException, match='source_frame is empty'):
        buffer.lookup_transform('a', '', 0)
    with pytest.raises(
        InvalidArgumentException, match=r'target_frame must be a frame name \(str\), not int'
    ):
        buffer.lookup_transform(7, 'b', 0)  # type: ignore[arg-type]
    for times in (np.array([1.5, 2.5]), np.zeros((2, 2), dtype=np.int64)):
        with pytest.raises(
            InvalidArgumentException, match='times must be a 1-D array of integer nanoseconds'
        ):
            buffer.lookup_transforms('a', 'b', times)


def test_same_frame_is_the_identity_and_leading_slashes_are_ignored() -> None:
    buffer = Buffer()
    buffer.add('/map', '/odom', 10, (1, 2, 3, 0, 0, 0, 1), 'ros1')
    assert buffer.lookup_transform('map', 'map', 0).transform.translation.x == 0.0
    assert buffer.lookup_transform('/map', 'odom', 10).transform.translation.y == 2.0
    with pytest.raises(LookupException):
        buffer.lookup_transform('nowhere', 'nowhere', 0)


# --- errors ---------------------------------------------------------------------------------


def nav_buffer() -> Buffer:
    buffer = Buffer()
    for stamp in (10 * 10**9, 11 * 10**9, 12 * 10**9):
        buffer.add('map', 'odom', stamp, (0, 0, 0, 0, 0, 0, 1), 'amcl')
        buffer.add('odom', 'base_link', stamp + 5 * 10**8, (1, 0, 0, 0, 0, 0, 1), 'odom')
    buffer.add('base_link', 'base_laser', 0, (0, 0, 1, 0, 0, 0, 1), 'rsp', static=True)
    buffer.add('world', 'camera_rig', 0, (0, 0, 1, 0, 0, 0, 1), 'rsp', static=True)
    return buffer


def test_unknown_frame_names_the_closest_known_frames() -> None:
    buffer = nav_buffer()
    with pytest.raises(LookupException) as caught:
        buffer.lookup_transform('map', 'base_lnk', 0)
    text = str(caught.value)
    assert '"base_lnk" passed to lookup_transform argument source_frame does not exist' in text
    assert '"base_link"' in text and '"base_laser"' in text
    with pytest.raises(LookupException, match=r'argument target_frame .* "map"'):
        buffer.lookup_transform('mapp', 'odom', 0)
    with pytest.raises(LookupException, match='holds no frames yet'):
        Buffer().lookup_transform('map', 'odom', 0)
    assert issubclass(LookupException, TransformException)
    assert issubclass(TransformException, ZrosError)


def test_two_trees_name_both_roots() -> None:
    buffer = nav_buffer()
    with pytest.raises(ConnectivityException) as caught:
        buffer.lookup_transform('camera_rig', 'base_laser', 0)
    text = str(caught.value)
    assert '"camera_rig" is in the tree rooted at "world"' in text
    assert '"base_laser" in the tree rooted at "map"' in text


def test_extrapolation_says_the_requested_time_and_the_range_the_chain_has() -> None:
    buffer = nav_buffer()
    with pytest.raises(ExtrapolationException) as caught:
        buffer.lookup_transform('map', 'base_laser', 13 * 10**9)
    text = str(caught.value)
    assert 'extrapolation into the future' in text
    assert 'Requested time 13.000000000' in text
    assert 'the chain has data from 10.500000000 to 12.000000000' in text
    assert 'from frame [base_laser] to frame [map]' in text
    with pytest.raises(ExtrapolationException, match=r'into the past. Requested time 9\.0+ but'):
        buffer.lookup_transform('map', 'base_laser', 9 * 10**9)
    # inside each edge's own data but not the other's: still the chain's range
    with pytest.raises(ExtrapolationException, match=r'earliest data is at time 10\.500000000'):
        buffer.lookup_transform('map', 'base_laser', 10_200_000_000)
    one = Buffer()
    one.add('a', 'b', 5, (0, 0, 0, 0, 0, 0, 1), 'test')
    with pytest.raises(
        ExtrapolationException, match=r'but only time 0\.000000005 is in the buffer'
    ):
        one.lookup_transform('a', 'b', 6)
    assert not buffer.can_transform('map', 'base_laser', 13 * 10**9)
    assert buffer.can_transform('map', 'base_laser', 11 * 10**9)


def test_chain_with_no_common_instant_says_so_with_each_edge_span() -> None:
    buffer = Buffer()
    buffer.add('a', 'b', 10, (0, 0, 0, 0, 0, 0, 1), 't')
    buffer.add('a', 'b', 20, (0, 0, 0, 0, 0, 0, 1), 't')
    buffer.add('b', 'c', 30, (0, 0, 0, 0, 0, 0, 1), 't')
    buffer.add('b', 'c', 40, (0, 0, 0, 0, 0, 0, 1), 't')
    with pytest.raises(ExtrapolationException, match=re.escape('no instant is covered')) as caught:
        buffer.lookup_transform('a', 'c', 0)
    assert 'a -> b [0.000000010, 0.000000020]' in str(caught.value)


def test_timeout_waits_for_data_and_then_raises_the_cause() -> None:
    buffer = nav_buffer()
    with pytest.raises(ExtrapolationException):
        buffer.lookup_transform('map', 'base_laser', 13 * 10**9, timeout=0.05)


def test_all_frames_as_yaml_and_string() -> None:
    buffer = nav_buffer()
    text = buffer.all_frames_as_string()
    assert 'Frame base_link exists with parent odom.\n' in text
    assert 'Frame odom exists with parent map.\n' in text
    yaml = buffer.all_frames_as_yaml()
    assert "base_link: \n  parent: 'odom'\n  broadcaster: 'odom'\n  rate: 1.500\n" in yaml
    assert '  most_recent_transform: 12.500\n  oldest_transform: 10.500\n' in yaml
    assert "base_laser: \n  parent: 'base_link'\n  broadcaster: 'rsp'\n  rate: 10000.000\n" in yaml
    from ruamel.yaml import YAML

    parsed = YAML(typ='safe').load(yaml)
    assert parsed['odom']['buffer_length'] == 2.0
    assert 'transform_delay: 0.500' in buffer.all_frames_as_yaml(Time(13 * 10**9))


def test_a_static_transform_sent_again_replaces_the_old_one_in_every_chain() -> None:
    buffer = Buffer()
    buffer.add('map', 'base', 10, (1, 0, 0, 0, 0, 0, 1), 'odom')
    buffer.add('base', 'arm', 0, (0, 1, 0, 0, 0, 0, 1), 'rsp', static=True)
    buffer.add('arm', 'hand', 0, (0, 0, 1, 0, 0, 0, 1), 'rsp', static=True)
    first = buffer.lookup_transform('map', 'hand', 10).transform.translation
    assert (first.x, first.y, first.z) == (1.0, 1.0, 1.0)
    buffer.add('base', 'arm', 0, (0, 2, 0, 0, 0, 0, 1), 'rsp', static=True)
    again = buffer.lookup_transform('map', 'hand', 10).transform.translation
    assert (again.x, again.y, again.z) == (1.0, 2.0, 1.0)
    t, _ = buffer.lookup_transforms('hand', 'map', [10])
    np.testing.assert_allclose(t, [[-1.0, -2.0, -1.0]], atol=TOL)


def test_rclpy_style_times_and_durations_are_taken_by_their_nanoseconds() -> None:
    class RclpyLike:  # rclpy.time.Time and rclpy.duration.Duration have .nanoseconds
        def __init__(self, nanoseconds: int) -> None:
            self.nanoseconds = nanoseconds

    buffer = Buffer()
    buffer.add('a', 'b', 10, (1, 0, 0, 0, 0, 0, 1), 'test')
    buffer.add('a', 'b', 20, (2, 0, 0, 0, 0, 0, 1), 'test')
    got = buffer.lookup_transform('a', 'b', RclpyLike(15), timeout=RclpyLike(10**6))  # type: ignore[arg-type]
    assert got.transform.translation.x == 1.5
    assert not buffer.can_transform('a', 'b', RclpyLike(25), timeout=RclpyLike(10**6))  # type: ignore[arg-type]


def test_clear_forgets_moving_transforms_and_keeps_static_ones() -> None:
    """tf2's clear: a static cache's clearList does nothing."""
    buffer = Buffer()
    identity = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    assert buffer.add('base', 'laser', 0, identity, 'urdf', static=True)
    assert buffer.add('odom', 'base', 5, identity, 'odometry')
    buffer.clear()
    assert buffer.can_transform('base', 'laser', 0)
    assert not buffer.can_transform('odom', 'base', 5)
    assert buffer.add('odom', 'base', 1, identity, 'odometry')  # older: taken, not old data


def test_a_waiting_lookup_words_its_error_only_when_read(monkeypatch: pytest.MonkeyPatch) -> None:
    """A lookup waiting for a frame tries again at every arrival; naming the closest of
    thousands of frames each time made every arriving transform cost milliseconds."""
    import threading

    import zros
    from zros.tf import tree

    worded: list[str] = []
    real = tree.unknown_frame_text

    def counted(frame: str, argument: str, frames: list[str]) -> str:
        worded.append(frame)
        return real(frame, argument, frames)

    monkeypatch.setattr(tree, 'unknown_frame_text', counted)
    buffer = Buffer()
    identity = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    for i in range(100):
        buffer.add('world', f'obj{i}', 0, identity, 'urdf', static=True)
    failures: list[Exception] = []

    def wait() -> None:
        try:
            buffer.lookup_transform('world', 'obj_x', 0, timeout=1.0)
        except LookupException as exc:
            failures.append(exc)

    waiter = threading.Thread(target=wait)
    waiter.start()
    stamp = 1
    while waiter.is_alive():  # arrivals while it waits: each wakes it
        transform = zros.Message('geometry_msgs/msg/TransformStamped')
        transform.header.frame_id, transform.child_frame_id = 'odom', 'base'
        transform.header.stamp = Time(stamp).to_msg()
        transform.transform.rotation.w = 1.0
        buffer.set_transform(transform, 'odometry')
        stamp += 1
    waiter.join()
    assert stamp > 10 and worded == []
    [failure] = failures
    assert 'the closest known frames: "obj' in str(failure)
    assert worded == ['obj_x']


def test_get_latest_common_time_is_what_a_time_zero_lookup_uses() -> None:
    buffer = Buffer()
    for stamp in (100, 300):
        buffer.add('map', 'odom', stamp, (0, 0, 0, 0, 0, 0, 1), 'amcl')
    buffer.add('odom', 'base', 250, (0, 0, 0, 0, 0, 0, 1), 'odom')
    buffer.add('base', 'laser', 0, (0, 0, 1, 0, 0, 0, 1), 'static', static=True)
    assert buffer.get_latest_common_time('map', 'laser') == Time(250)
    assert buffer.get_latest_common_time('base', 'laser') == Time(0)
    assert buffer.get_latest_common_time('laser', 'laser') == Time(0)
    with pytest.raises(LookupException):
        buffer.get_latest_common_time('map', 'nowhere')
    buffer.add('elsewhere', 'cam', 0, (0, 0, 0, 0, 0, 0, 1), 'static', static=True)
    with pytest.raises(ConnectivityException):
        buffer.get_latest_common_time('map', 'cam')


def test_the_frames_of_a_chain() -> None:
    """Buffer.chain (tf2's _chainAsVector): source first, through the common ancestor."""
    buffer = Buffer()
    one = (1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    for parent, child in (('map', 'odom'), ('odom', 'base'), ('base', 'laser'), ('base', 'arm')):
        buffer.add(parent, child, 10**9, one, 'test')
    assert buffer.chain('arm', 'laser') == ['laser', 'base', 'arm']
    assert buffer.chain('map', 'laser') == ['laser', 'base', 'odom', 'map']
    assert buffer.chain('laser', 'map') == ['map', 'odom', 'base', 'laser']
    assert buffer.chain('base', 'base') == ['base']
    with pytest.raises(LookupException, match='"lazer"'):
        buffer.chain('map', 'lazer')
