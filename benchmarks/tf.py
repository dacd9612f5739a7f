"""Transform lookups: zros.tf against pytransform3d's TemporalTransformManager and against a
per-stamp loop over ``lookup_transform``, in the same process.

1. one ``lookup_transform`` through a 5-edge chain (two moving edges, three static), the
   TransformStamped message included (goal: <= 20 us);
2. ``lookup_transforms`` of 1,000,000 stamps through a 3-edge chain with one moving edge
   (10,000 samples; goal: <= 1.0 s), beside pytransform3d answering the same array and a loop
   of one ``lookup_transform`` per stamp (timed on ``--loop`` stamps, scaled to the whole);
3. ``lookup_transforms`` of a few stamps (1 to 1,000) on a long edge (an hour at 50 Hz, 180,000
   samples), beside a loop of ``lookup_transform``: a call costs what its stamps cost, not what
   the edge holds (goal: 1 stamp <= 1 ms).

Prints the medians of ``--repeat`` runs after one warm-up, the ratios, the peak memory each bulk method
allocated (tracemalloc, numpy's arrays included) and the process's peak RSS.

    python benchmarks/tf.py
    python benchmarks/tf.py --stamps 200000 --repeat 3
"""

from __future__ import annotations

import argparse
import math
import resource
import statistics
import time
import tracemalloc
from collections.abc import Callable

import numpy as np

from zros.tf import Buffer

SECOND = 1_000_000_000


def moving(rng: np.random.Generator, count: int, period: int) -> tuple[np.ndarray, np.ndarray]:
    """``count`` samples ``period`` ns apart of a frame driving and turning: stamps, (N, 7)."""
    stamps = np.arange(count, dtype=np.int64) * period + SECOND
    yaw = np.cumsum(rng.normal(0.0, 0.02, count))
    rows = np.zeros((count, 7))
    rows[:, 0] = np.cumsum(np.cos(yaw)) * 0.01
    rows[:, 1] = np.cumsum(np.sin(yaw)) * 0.01
    rows[:, 5] = np.sin(yaw / 2)
    rows[:, 6] = np.cos(yaw / 2)
    return stamps, rows


STATIC = (0.2, 0.0, 0.3, 0.0, 0.0, math.sin(0.2), math.cos(0.2))


def fill(edges: list[tuple[str, str, np.ndarray | None, np.ndarray]]) -> Buffer:
    buffer = Buffer(cache_time=None)
    for parent, child, stamps, rows in edges:
        if stamps is None:
            buffer.add(parent, child, 0, tuple(rows.tolist()), 'bench', static=True)
            continue
        for stamp, row in zip(stamps.tolist(), rows.tolist(), strict=True):
            buffer.add(parent, child, stamp, tuple(row), 'bench')
    return buffer


def manager(edges: list[tuple[str, str, np.ndarray | None, np.ndarray]]) -> object:
    from pytransform3d.transform_manager import (
        NumpyTimeseriesTransform,
        StaticTransform,
        TemporalTransformManager,
    )
    from pytransform3d.transformations import transform_from_pq

    tm = TemporalTransformManager(check=False)
    for parent, child, stamps, rows in edges:
        pq = np.c_[
            np.atleast_2d(rows)[:, :3], np.atleast_2d(rows)[:, 6], np.atleast_2d(rows)[:, 3:6]
        ]
        if stamps is None:
            tm.add_transform(child, parent, StaticTransform(transform_from_pq(pq[0])))
        else:
            tm.add_transform(child, parent, NumpyTimeseriesTransform(stamps / SECOND, pq))
    return tm


def median_time(function: Callable[[], object], repeat: int) -> float:
    function()  # warm: message classes compiled, chains found, pages touched
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def peak_allocated(function: Callable[[], object]) -> int:
    tracemalloc.start()
    try:
        function()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def one_lookup(rng: np.random.Generator, repeat: int) -> None:
    odom_stamps, odom_rows = moving(rng, 1000, SECOND // 10)  # 100 s at 10 Hz
    base_stamps, base_rows = moving(rng, 5000, SECOND // 50)  # 100 s at 50 Hz
    edges = [
        ('map', 'odom', odom_stamps, odom_rows),
        ('odom', 'base_link', base_stamps, base_rows),
        ('base_link', 'torso', None, np.array(STATIC)),
        ('torso', 'head', None, np.array(STATIC)),
        ('head', 'camera', None, np.array(STATIC)),
    ]
    buffer = fill(edges)
    tm = manager(edges)
    stamps = rng.integers(2 * SECOND, 99 * SECOND, 2000).tolist()

    def zros_lookups() -> None:
        for stamp in stamps:
            buffer.lookup_transform('map', 'camera', stamp)

    def pytransform3d_lookups() -> None:
        for stamp in stamps:
            tm.get_transform_at_time('camera', 'map', stamp / SECOND)  # type: ignore[attr-defined]

    ours = median_time(zros_lookups, repeat) / len(stamps) * 1e6
    theirs = median_time(pytransform3d_lookups, repeat) / len(stamps) * 1e6
    print('one lookup through a 5-edge chain (2 moving, 3 static), median of runs of 2,000:')
    print(f'  zros lookup_transform (TransformStamped)   {ours:9.1f} us   (goal <= 20 us)')
    print(
        f'  pytransform3d get_transform_at_time (4x4)  {theirs:9.1f} us   {theirs / ours:6.1f}x zros'
    )


def many_stamps(rng: np.random.Generator, count: int, loop: int, repeat: int) -> None:
    stamps, rows = moving(rng, 10_000, SECOND // 100)  # 100 s at 100 Hz
    edges = [
        ('map', 'odom', stamps, rows),
        ('odom', 'base_link', None, np.array(STATIC)),
        ('base_link', 'laser', None, np.array(STATIC)),
    ]
    buffer = fill(edges)
    tm = manager(edges)
    times = np.sort(rng.integers(int(stamps[0]), int(stamps[-1]), count)).astype(np.int64)

    def zros_many() -> tuple[np.ndarray, np.ndarray]:
        return buffer.lookup_transforms('map', 'laser', times)

    def pytransform3d_many() -> np.ndarray:
        return tm.get_transform_at_time('laser', 'map', times / SECOND)  # type: ignore[attr-defined,no-any-return]

    few = times[:: max(1, count // loop)][:loop].tolist()

    def zros_loop() -> None:
        for stamp in few:
            buffer.lookup_transform('map', 'laser', stamp)

    ours = median_time(zros_many, repeat)
    ours_peak = peak_allocated(zros_many)
    rss_after_zros = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    theirs = median_time(pytransform3d_many, repeat)
    theirs_peak = peak_allocated(pytransform3d_many)
    per_stamp = median_time(zros_loop, repeat) / len(few) * count
    t, _ = zros_many()
    matrices = pytransform3d_many()
    gap = np.abs(matrices[:, :3, 3] - t).max()
    print(f'{count:,} stamps through a 3-edge chain (one moving edge of 10,000 samples):')
    print(
        f'  zros lookup_transforms        {ours:8.3f} s   peak {ours_peak / 2**20:7.0f} MiB allocated   (goal <= 1.0 s)'
    )
    print(
        f'  pytransform3d (array query)   {theirs:8.3f} s   peak {theirs_peak / 2**20:7.0f} MiB allocated   {theirs / ours:6.1f}x zros'
    )
    print(
        f'  loop of lookup_transform      {per_stamp:8.3f} s   (timed on {len(few):,} stamps)      {per_stamp / ours:6.1f}x zros'
    )
    print(
        f'  largest translation difference, ScLERP (pytransform3d) vs lerp+slerp: {gap * 1000:.3f} mm'
    )
    print(f'  peak RSS of the process after zros: {rss_after_zros:.0f} MiB; at the end: '
          f'{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB')  # fmt: skip


def few_stamps(rng: np.random.Generator, repeat: int) -> None:
    stamps, rows = moving(rng, 180_000, SECOND // 50)  # an hour at 50 Hz
    buffer = fill([('odom', 'base_link', stamps, rows)])
    print('a few stamps on an edge of 180,000 samples (an hour at 50 Hz), median per call:')
    for count in (1, 10, 100, 1000):
        times = np.sort(rng.integers(int(stamps[0]), int(stamps[-1]), count)).astype(np.int64)
        listed = times.tolist()

        def many(times: np.ndarray = times) -> object:
            return buffer.lookup_transforms('odom', 'base_link', times)

        def loop(listed: list[int] = listed) -> None:
            for stamp in listed:
                buffer.lookup_transform('odom', 'base_link', stamp)

        ours, looped = median_time(many, repeat), median_time(loop, repeat)
        goal = '   (goal <= 1 ms)' if count == 1 else ''
        print(
            f'  {count:5,} stamps: lookup_transforms {ours * 1e3:7.3f} ms, '
            f'loop of lookup_transform {looped * 1e3:7.3f} ms{goal}'
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--stamps', type=int, default=1_000_000)
    parser.add_argument('--loop', type=int, default=20_000, help='stamps the loop is timed on')
    parser.add_argument('--repeat', type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(7)
    one_lookup(rng, args.repeat)
    many_stamps(rng, args.stamps, args.loop, args.repeat)
    few_stamps(rng, args.repeat)


if __name__ == '__main__':
    from readme import recording

    with recording(__file__):
        main()
