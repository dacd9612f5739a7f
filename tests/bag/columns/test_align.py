"""Bag.align and Bag.synchronize against answers worked out by hand."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from tests.bag.makebags import make_sensor_bag
from zros.bag import Bag, BagError, BagTopic, BagWriter
from zros.cdr import default_registry, encode, new_message

POINT = 'geometry_msgs/msg/PointStamped'
NaN = np.nan


def point(stamp: int, x: float) -> bytes:
    header = new_message('std_msgs/msg/Header', stamp=new_message(
        'builtin_interfaces/msg/Time', sec=stamp // 10**9, nanosec=stamp % 10**9
    ))  # fmt: skip
    return encode(
        new_message(POINT, header=header, point=new_message('geometry_msgs/msg/Point', x=x))
    )


def write(path: Path, topics: dict[str, str], messages: list[tuple[str, int, bytes]]) -> Path:
    """A bag of ``topics`` (name -> type) holding ``messages`` (topic, receive time, CDR)."""
    registry = default_registry()
    with BagWriter(path) as writer:
        index = {
            name: writer.add_topic(BagTopic.from_registry(registry, name, type_name))
            for name, type_name in topics.items()
        }
        for topic, received, data in messages:
            writer.write(index[topic], received, data)
    return path


@pytest.fixture(scope='module')
def two(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """/a stamped 10, 20, 30 (x = 1, 2, 3); /b received with stamps out of order: 25, 14, 15,
    then 25 again (x = 26: of equal stamps the last received counts); /c empty; /f headerless
    Float64 received at 12 and 28; /flag headerless Bool received at 12 (False), 28 (True)."""
    f64 = 'std_msgs/msg/Float64'
    flag = 'std_msgs/msg/Bool'
    return write(
        tmp_path_factory.mktemp('align') / 'bag',
        {'/a': POINT, '/b': POINT, '/c': POINT, '/f': f64, '/flag': flag},
        [
            ('/a', 100, point(10, 1.0)),
            ('/b', 101, point(25, 25.0)),
            ('/f', 12, encode(new_message(f64, data=1.0))),
            ('/flag', 12, encode(new_message(flag, data=False))),
            ('/b', 102, point(14, 14.0)),
            ('/b', 103, point(15, 15.0)),
            ('/a', 200, point(20, 2.0)),
            ('/f', 28, encode(new_message(f64, data=2.6))),
            ('/flag', 28, encode(new_message(flag, data=True))),
            ('/b', 250, point(25, 26.0)),
            ('/a', 300, point(30, 3.0)),
        ],
    )


def values(table: np.ndarray, name: str) -> list[float]:
    return table[name].tolist()


def same(got: list[float], expected: list[float]) -> bool:
    return np.array_equal(np.asarray(got), np.asarray(expected), equal_nan=True)


@pytest.mark.parametrize(
    ('method', 'tolerance', 'expected'),
    [
        ('previous', None, [NaN, 15.0, 26.0]),
        ('nearest', None, [14.0, 15.0, 26.0]),  # 20: 15 and 25 are 5 away, the earlier wins
        ('nearest', 4e-9, [14.0, NaN, NaN]),  # within 4 ns, inclusive
        ('previous', 5e-9, [NaN, 15.0, 26.0]),
        ('linear', None, [NaN, 20.5, NaN]),  # 20 = halfway from 15 (15.0) to 25 (26.0)
        ('linear', 4e-9, [NaN, NaN, NaN]),  # both neighbours must lie within the tolerance
    ],
)
def test_methods_on_a_topic(
    two: Path, method: str, tolerance: float | None, expected: list[float]
) -> None:
    with Bag(two) as bag:
        table = bag.align(['/a.point.x', '/b.point.x'], on='/a', method=method, tolerance=tolerance)
    assert table.dtype.names == ('time', '/a.point.x', '/b.point.x')
    assert table['time'].tolist() == [10, 20, 30]
    assert values(table, '/a.point.x') == [1.0, 2.0, 3.0]  # the reference: its own rows
    assert same(values(table, '/b.point.x'), expected)


def test_out_of_order_reference_rows_follow_the_stamps(two: Path) -> None:
    with Bag(two) as bag:
        table = bag.align({'/b': ['point.x'], '/a': 'point.x'}, on='/b', method='previous')
    assert table['time'].tolist() == [14, 15, 25, 25]  # every /b message, in stamp order
    assert values(table, '/b.point.x') == [14.0, 15.0, 25.0, 26.0]
    assert same(values(table, '/a.point.x'), [10 / 10, 1.0, 2.0, 2.0])


def test_a_period_spans_every_topic_and_an_empty_topic_is_nan(two: Path) -> None:
    with Bag(two) as bag:
        table = bag.align(['/a.point.x', '/b.point.x', '/c.point.x'], on=1e-8, method='previous')
        empty = bag.align(['/a.point.x'], on='/c')
    assert table['time'].tolist() == [10, 20, 30]
    assert values(table, '/a.point.x') == [1.0, 2.0, 3.0]
    assert same(values(table, '/b.point.x'), [NaN, 15.0, 26.0])
    assert same(values(table, '/c.point.x'), [NaN, NaN, NaN])
    assert len(empty) == 0 and empty.dtype.names == ('time', '/a.point.x')


def test_a_struct_selects_its_fields_and_a_bare_topic_all(two: Path) -> None:
    with Bag(two) as bag:
        table = bag.align(['/a.point', '/b'], on='/a')
    names = table.dtype.names
    assert names[:4] == ('time', '/a.point.x', '/a.point.y', '/a.point.z')
    assert '/b.header.stamp.sec' in names and '/b.point.z' in names


def test_headerless_topics_use_receive_time_and_say_so(two: Path) -> None:
    with Bag(two) as bag, pytest.warns(UserWarning, match='no header stamp in /f: receive times'):
        table = bag.align(['/f.data'], on='/a', method='linear')
    assert same(values(table, '/f.data'), [NaN, 1.8, NaN])  # 20 is half way from 12 to 28


def test_receive_stamps(two: Path) -> None:
    with Bag(two) as bag, warnings.catch_warnings():
        warnings.simplefilter('error')
        table = bag.align(['/b.point.x', '/f.data'], on='/a', stamp='receive', method='previous')
    assert table['time'].tolist() == [100, 200, 300]
    assert same(values(table, '/b.point.x'), [NaN, 15.0, 26.0])  # received 101..103, 250
    assert values(table, '/f.data') == [2.6, 2.6, 2.6]


def test_linear_names_what_it_cannot_interpolate(two: Path) -> None:
    with Bag(two) as bag, pytest.warns(UserWarning, match=r'cannot interpolate /flag\.data'):
        table = bag.align(['/flag.data', '/f.data'], on=4e-9, method='linear', stamp='receive')
    times = table['time'].tolist()
    assert times[0] == 12 and times[-1] == 28
    at = {
        t: (f, v)
        for t, f, v in zip(
            times, values(table, '/flag.data'), values(table, '/f.data'), strict=True
        )
    }
    assert at[20] == (0.0, 1.8)  # a tie takes the earlier
    assert at[24] == (1.0, pytest.approx(2.2))
    assert at[12] == (0.0, 1.0) and at[28] == (1.0, 2.6)


def test_as_dataframe(two: Path) -> None:
    pytest.importorskip('pandas')
    with Bag(two) as bag:
        frame = bag.align(
            ['/a.point.x', '/b.point.x'], on='/a', method='previous', as_dataframe=True
        )
    assert list(frame.columns) == ['time', '/a.point.x', '/b.point.x']
    assert same(frame['/b.point.x'].tolist(), [NaN, 15.0, 26.0])


@pytest.mark.parametrize(
    ('kwargs', 'error', 'match'),
    [
        ({'method': 'cubic'}, ValueError, 'method is one of nearest, previous, linear'),
        ({'stamp': 'publish'}, ValueError, 'stamp is one of header, receive'),
        ({'tolerance': -1.0}, ValueError, 'tolerance must be seconds >= 0'),
        ({'on': 0.0}, ValueError, 'period on= must be positive'),
        ({'on': True}, TypeError, 'on= is a topic name or a period'),
        ({'on': '/nope'}, BagError, 'no topic /nope'),
        ({'columns': ['/a.point.w']}, BagError, "topic /a: .* has no field 'point.w'"),
        ({'columns': ['/a.header.frame_id']}, BagError, 'not numeric'),
        ({'columns': []}, ValueError, 'at least one topic'),
    ],
)
def test_bad_arguments(
    two: Path, kwargs: dict[str, object], error: type[Exception], match: str
) -> None:
    arguments: dict[str, object] = {'columns': ['/a.point.x'], 'on': '/a', **kwargs}
    with Bag(two) as bag, pytest.raises(error, match=match):
        bag.align(**arguments)  # type: ignore[arg-type]


@pytest.fixture(scope='module')
def sensors(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_sensor_bag(tmp_path_factory.mktemp('sensors') / 'bag', 60)


def test_fixed_arrays_stay_2d_and_ragged_sequences_are_refused(sensors: Path) -> None:
    with Bag(sensors) as bag:
        table = bag.align(['/imu.orientation_covariance', '/odom.twist.twist.linear.x'], on='/imu')
        assert table['/imu.orientation_covariance'].shape == (20, 9)
        assert np.array_equal(
            table['/imu.orientation_covariance'], bag.columns('/imu')['orientation_covariance']
        )
        with pytest.raises(BagError, match=r'/scan\.ranges holds sequences of different lengths'):
            bag.align(['/scan.ranges'], on='/imu')


# --- synchronize --------------------------------------------------------------------------


def test_synchronize_matches_as_the_live_synchronizer(tmp_path: Path) -> None:
    """slop 10 ns, fed in receive order: a100+b95; b120 waits; a131 is 11 from b120; a125
    takes b120; b140 takes a131; a200 and b210 span 10, not less: no match; b304 picks the
    closest of a300 and a306."""
    msgs = [
        ('/a', 1, point(100, 100)),
        ('/b', 2, point(95, 95)),
        ('/b', 3, point(120, 120)),
        ('/a', 4, point(131, 131)),
        ('/a', 5, point(125, 125)),
        ('/b', 6, point(140, 140)),
        ('/a', 7, point(200, 200)),
        ('/b', 8, point(210, 210)),
        ('/a', 9, point(300, 300)),
        ('/a', 10, point(306, 306)),
        ('/b', 11, point(304, 304)),
    ]
    path = write(tmp_path / 'bag', {'/a': POINT, '/b': POINT, '/f': 'std_msgs/msg/Float64'}, msgs)
    with Bag(path) as bag:
        got = [(a.point.x, b.point.x) for a, b in bag.synchronize(['/a', '/b'], 10e-9)]
        flipped = [(a.point.x, b.point.x) for b, a in bag.synchronize(['/b', '/a'], 10e-9)]
        short = [(a.point.x, b.point.x) for a, b in bag.synchronize(['/a', '/b'], 10e-9, 1)]
    assert got == [(100, 95), (125, 120), (131, 140), (306, 304)]
    # one stamp per queue: a125 is older than the waiting a131 and dropped at once, and
    # b140 replaces b120
    assert short == [(100, 95), (131, 140), (306, 304)]
    assert flipped == got


def test_synchronize_skips_headerless_or_stamps_them_with_receive_time(two: Path) -> None:
    with Bag(two) as bag:
        with pytest.warns(UserWarning, match='/f has no header stamp'):
            assert list(bag.synchronize(['/a', '/f'], 1.0)) == []
        pairs = list(bag.synchronize(['/f', '/a'], 5e-9, allow_headerless=True))
        assert list(bag.synchronize(['/a', '/c'], 1.0)) == []  # /c is empty
        with pytest.raises(ValueError, match='each topic once'):
            bag.synchronize(['/a', '/a'], 1.0)
        with pytest.raises(BagError, match='no topic /nope'):
            bag.synchronize(['/a', '/nope'], 1.0)
        with pytest.raises(ValueError, match='slop must not be negative'):
            bag.synchronize(['/a', '/f'], -1.0)
        with pytest.raises(ValueError, match='queue_size must be at least 1'):
            bag.synchronize(['/a', '/f'], 1.0, queue_size=0)
    # /f received at 12 and 28 meets /a stamped 10 and 30 (2 ns apart)
    assert [(f.data, a.point.x) for f, a in pairs] == [(1.0, 1.0), (2.6, 3.0)]


def test_a_period_grid_too_large_is_refused_before_it_is_made(
    two: Path, testdata: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from zros.bag.columns import align

    with Bag(testdata / 'ros2' / 'talker_mcap') as bag, pytest.raises(ValueError) as raised:
        bag.align(['/rosout.level'], on=1e-9, stamp='receive')  # once: MemoryError, 720 GiB
    assert 'rows (at most 100,000,000): use a longer period' in str(raised.value)
    monkeypatch.setattr(align, 'MAX_GRID_ROWS', 20)
    with Bag(two) as bag:  # /a and /b span 10 to 30 ns: 21 rows of 1 ns
        with pytest.raises(ValueError) as raised:
            bag.align(['/a.point.x', '/b.point.x'], on=1e-9)
        assert str(raised.value) == (
            'a period of 1e-09 s over 0.000 s of data is 21 rows (at most 20): use a longer '
            "period, or on='/topic' for a row per message of that topic"
        )
        monkeypatch.setattr(align, 'MAX_GRID_ROWS', 21)
        assert len(bag.align(['/a.point.x', '/b.point.x'], on=1e-9)) == 21
