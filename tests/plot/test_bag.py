"""Plots from recordings: the bag's time axis, the recorded values, parts of it, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import zros
from zros.bag import BagTopic, BagWriter
from zros.cdr import default_registry, encode
from zros.plot import PlotError, moving_average
from zros.plot import bag as plot_bag

START = 1_700_000_000 * 10**9  #: the recording's first receive time
COUNT = 40


def speed(n: int) -> float:
    """The recorded forward speed of odometry message n."""
    return 0.5 + 0.25 * np.sin(n / 5)


def make_bag(path: Path) -> Path:
    """/odom every 100 ms from START + 0.5 s; /joint_states (2 or 3 joints) every 250 ms
    from START."""
    registry = default_registry()
    with BagWriter(path) as writer:
        odom = writer.add_topic(BagTopic.from_registry(registry, '/odom', 'nav_msgs/msg/Odometry'))
        joints = writer.add_topic(
            BagTopic.from_registry(registry, '/joint_states', 'sensor_msgs/msg/JointState')
        )
        for n in range(16):
            positions = [float(n), -float(n)] + ([n / 10] if n % 2 else [])
            message = zros.Message('sensor_msgs/msg/JointState', position=positions)
            writer.write(joints, START + n * 250_000_000, encode(message))
        for n in range(COUNT):
            message = zros.Message('nav_msgs/msg/Odometry')
            message.twist.twist.linear.x = speed(n)
            message.pose.pose.position.x = n * 0.05
            writer.write(odom, START + 500_000_000 + n * 100_000_000, encode(message))
    return path


def test_fields_against_the_bags_time(tmp_path: Path) -> None:
    bag = make_bag(tmp_path / 'run1')
    figure = plot_bag(bag, ['/odom/twist/twist/linear/x', '/odom/pose/pose/position/x'],
                      png=tmp_path / 'odom.png', filter=4)  # fmt: skip
    axes = figure.axes[0]
    speed_line, speed_avg, position_line, position_avg = axes.lines
    expected_times = 0.5 + np.arange(COUNT) * 0.1  # seconds from the first message of the bag
    assert np.allclose(speed_line.get_xdata(), expected_times)
    assert np.allclose(speed_line.get_ydata(), [speed(n) for n in range(COUNT)])
    assert np.allclose(speed_avg.get_ydata(), moving_average(speed_line.get_ydata(), 4))
    assert np.allclose(position_line.get_ydata(), np.arange(COUNT) * 0.05)
    assert np.allclose(position_avg.get_xdata(), expected_times)
    assert axes.get_title() == 'run1: /odom'
    assert axes.get_xlabel() == 'time since the start of the recording [s]'
    assert axes.get_ylabel() == 'value'
    assert [t.get_text() for t in axes.get_legend().get_texts()] == [
        '/odom/twist/twist/linear/x',
        '/odom/twist/twist/linear/x, moving average of 4',
        '/odom/pose/pose/position/x',
        '/odom/pose/pose/position/x, moving average of 4',
    ]
    assert axes.get_xlim() == pytest.approx((0.0, 0.5 + (COUNT - 1) * 0.1))
    low, high = axes.get_ylim()
    assert low < 0.0 and high > (COUNT - 1) * 0.05
    assert (tmp_path / 'odom.png').stat().st_size > 10_000


def test_elements_of_sequences_and_a_part_of_the_bag(tmp_path: Path) -> None:
    bag = make_bag(tmp_path / 'run2')
    figure = plot_bag(bag, ['/joint_states/position[2]', '/joint_states/position/0'],
                      start=1.0, end=3.0)  # fmt: skip
    third, first = figure.axes[0].lines
    times = np.asarray(first.get_xdata())
    assert np.allclose(times, np.arange(4, 12) * 0.25)  # 1.0 <= t < 3.0
    assert first.get_ydata().tolist() == [float(n) for n in range(4, 12)]
    # joint 2 exists in the odd messages only: gaps elsewhere
    expected = [n / 10 if n % 2 else np.nan for n in range(4, 12)]
    assert np.array_equal(third.get_ydata(), expected, equal_nan=True)
    assert figure.axes[0].get_xlim() == (1.0, 3.0)
    assert figure.axes[0].get_title() == 'run2: /joint_states'


def test_an_address_the_bag_does_not_have(tmp_path: Path) -> None:
    bag = make_bag(tmp_path / 'run3')
    with pytest.raises(PlotError) as raised:
        plot_bag(bag, ['/imu/x'])
    assert str(raised.value) == (
        '/imu/x: no topic of run3 starts this address; it has: /odom, /joint_states'
    )
    with pytest.raises(PlotError, match="/odom/twist/speed: twist has no field 'speed'"):
        plot_bag(bag, ['/odom/twist/speed'])


def test_a_type_defined_nowhere_in_the_bag(tmp_path: Path) -> None:
    from tests.bag.test_reader import SECRET, secret_bag
    from zros.bag import BagError

    bag, _ = secret_bag(tmp_path / 'secret')
    figure = plot_bag(bag, ['/point/x'])  # the other topics plot
    assert figure.axes[0].lines[0].get_ydata().tolist() == [0.0, 1.0, 2.0]
    with pytest.raises(BagError, match=f'{SECRET}, which has no definition.*register_type'):
        plot_bag(bag, ['/secret/code'])


def test_an_element_past_the_end_of_every_array(tmp_path: Path) -> None:
    bag = make_bag(tmp_path / 'run4')
    with pytest.raises(PlotError) as raised:
        plot_bag(bag, ['/joint_states/position[5]'])
    assert str(raised.value) == (
        '/joint_states/position[5]: position has 2, 3 elements in this recording, no element 5'
    )
    with pytest.raises(PlotError, match=r'^/joint_states/velocity/1: velocity has 0 elements'):
        plot_bag(bag, ['/joint_states/velocity/1'])


def test_an_element_past_the_end_of_a_real_recording(testdata: Path) -> None:
    bag = testdata / 'ros1' / 'tf_franka.bag'
    with pytest.raises(
        PlotError, match=r'position has 9 elements in this recording, no element 20'
    ):
        plot_bag(bag, ['/joint_states/position[20]'])
