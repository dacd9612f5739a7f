"""``lookup_transforms``: the same answers as one lookup per stamp, NaN rows outside what the
chain covers, ``strict`` naming the first such stamp."""

from __future__ import annotations

import numpy as np
import pytest

from tests.tf.trees import random_tree
from zros.tf import Buffer, ExtrapolationException, InvalidArgumentException, LookupException

TOL = 1e-9


def one_by_one(buffer: Buffer, target: str, source: str, stamps: np.ndarray) -> np.ndarray:
    rows = []
    for stamp in stamps:
        try:
            t = buffer.lookup_transform(target, source, int(stamp)).transform
        except ExtrapolationException:
            rows.append([np.nan] * 7)
            continue
        tr, q = t.translation, t.rotation
        rows.append([tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w])
    return np.array(rows)


def same_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``b`` with each quaternion's sign matched to ``a`` (q and -q are one rotation)."""
    sign = np.where(np.einsum('ij,ij->i', np.nan_to_num(a), np.nan_to_num(b)) < 0, -1.0, 1.0)
    return b * sign[:, None]


@pytest.mark.parametrize('depth', [1, 3, 5, 8])
def test_vectorised_lookups_equal_one_lookup_per_stamp(depth: int) -> None:
    rng = np.random.default_rng(200 + depth)
    tree = random_tree(rng, depth, samples=12)
    buffer = tree.buffer()
    frames = sorted({*tree.edges, *(e.parent for e in tree.edges.values())})
    for _ in range(10):
        target, source = rng.choice(frames, 2)
        stamps = np.sort(rng.integers(9 * 10**8, 21 * 10**8, 300)).astype(np.int64)
        every = np.unique(np.concatenate([e.stamps for e in tree.edges.values()]))
        # exact sample stamps too (not 0, which one lookup reads as 'the latest')
        stamps = np.concatenate((stamps, every[every > 0]))
        translations, rotations = buffer.lookup_transforms(target, source, stamps)
        expected = one_by_one(buffer, target, source, stamps)
        np.testing.assert_array_equal(np.isnan(translations[:, 0]), np.isnan(expected[:, 0]))
        np.testing.assert_allclose(translations, expected[:, :3], atol=TOL)
        np.testing.assert_allclose(rotations, same_rotation(rotations, expected[:, 3:]), atol=TOL)


def test_stamps_outside_the_chain_are_nan_rows_or_strict_names_the_first() -> None:
    buffer = Buffer(cache_time=None)
    buffer.add('map', 'odom', 100, (0, 0, 0, 0, 0, 0, 1), 't')
    buffer.add('map', 'odom', 200, (1, 0, 0, 0, 0, 0, 1), 't')
    buffer.add('odom', 'base', 0, (0, 1, 0, 0, 0, 0, 1), 't', static=True)
    stamps = np.array([100, 150, 250, 200, 50], dtype=np.int64)
    t, q = buffer.lookup_transforms('map', 'base', stamps)
    assert t.shape == (5, 3) and q.shape == (5, 4)
    np.testing.assert_allclose(t[[0, 1, 3]], [[0, 1, 0], [0.5, 1, 0], [1, 1, 0]], atol=TOL)
    assert np.isnan(t[[2, 4]]).all() and np.isnan(q[[2, 4]]).all()
    with pytest.raises(ExtrapolationException, match=r'times\[2\]: .*Requested time 0.000000250'):
        buffer.lookup_transforms('map', 'base', stamps, strict=True)
    inverse, _ = buffer.lookup_transforms('base', 'map', stamps[:2])
    np.testing.assert_allclose(inverse, [[0, -1, 0], [-0.5, -1, 0]], atol=TOL)


def test_static_chains_same_frames_and_empty_arrays() -> None:
    buffer = Buffer()
    buffer.add('a', 'b', 0, (1, 2, 3, 0, 0, 0, 1), 't', static=True)
    t, q = buffer.lookup_transforms('a', 'b', np.array([0, 10**18], dtype=np.int64))
    np.testing.assert_array_equal(t, [[1, 2, 3], [1, 2, 3]])
    t, q = buffer.lookup_transforms('a', 'a', [5, 6])
    np.testing.assert_array_equal(q, [[0, 0, 0, 1], [0, 0, 0, 1]])
    t, q = buffer.lookup_transforms('a', 'b', np.zeros(0, dtype=np.int64))
    assert t.shape == (0, 3) and q.shape == (0, 4)


def test_bad_arguments() -> None:
    buffer = Buffer()
    buffer.add('a', 'b', 0, (1, 2, 3, 0, 0, 0, 1), 't', static=True)
    with pytest.raises(InvalidArgumentException, match='integer nanoseconds'):
        buffer.lookup_transforms('a', 'b', np.array([1.5]))
    with pytest.raises(InvalidArgumentException, match='1-D'):
        buffer.lookup_transforms('a', 'b', np.zeros((2, 2), dtype=np.int64))
    with pytest.raises(LookupException, match='"c" passed'):
        buffer.lookup_transforms('a', 'c', [1])


def test_numpy_integer_times_are_times() -> None:
    # bag columns give int64 stamps; a lookup at one of them is a lookup at that time
    buffer = Buffer()
    buffer.add('a', 'b', 10, (1, 0, 0, 0, 0, 0, 1), 't')
    buffer.add('a', 'b', 20, (3, 0, 0, 0, 0, 0, 1), 't')
    buffer.add('a', 'c', 0, (0, 0, 0, 0, 0, 0, 1), 't', static=True)
    for stamp in (np.int64(15), np.uint32(15), np.int16(15)):
        assert buffer.lookup_transform('a', 'b', stamp).transform.translation.x == 2.0
        full = buffer.lookup_transform_full('c', stamp, 'b', np.int64(20), 'a')
        assert full.transform.translation.x == 3.0  # b at its source time 20
        assert full.header.stamp.nanosec == 15
    for wrong in (np.float64(15), True):
        with pytest.raises(InvalidArgumentException, match='integer nanoseconds'):
            buffer.lookup_transform('a', 'b', wrong)
