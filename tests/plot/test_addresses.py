"""Addresses: where the topic ends, which field, which element; the moving average."""

from __future__ import annotations

import numpy as np
import pytest

import zros
from zros.bag.columns.addresses import split_address
from zros.cdr import default_registry
from zros.plot import PlotError, Series, moving_average, resolve

TOPICS = {
    '/imu': 'sensor_msgs/msg/Imu',
    '/robot': 'std_msgs/msg/Float64',
    '/robot/odom': 'nav_msgs/msg/Odometry',
    '/joint_states': 'sensor_msgs/msg/JointState',
    '/voltage': 'std_msgs/msg/Float32',
    '/range': 'sensor_msgs/msg/Range',
}


def classes(topic: str, type_name: str) -> type:
    return default_registry().get_class(type_name)


def fields(address: str) -> list[tuple[str, str, int | None]]:
    return [(s.topic, s.field, s.index) for s in resolve(address, TOPICS, classes)]


def test_the_longest_topic_that_has_the_field_wins() -> None:
    assert split_address('/robot/odom/twist/twist/linear/x', list(TOPICS)) == [
        ('/robot/odom', 'twist/twist/linear/x'),
        ('/robot', 'odom/twist/twist/linear/x'),
    ]
    assert fields('/robot/odom/twist/twist/linear/x') == [
        ('/robot/odom', 'twist.twist.linear.x', None)
    ]
    # /robot/odom has no field 'data': the shorter topic /robot (a Float64) has
    assert fields('/robot/data') == [('/robot', 'data', None)]
    assert fields('/imu/linear_acceleration/x') == [('/imu', 'linear_acceleration.x', None)]


def test_a_message_field_stands_for_its_numbers_and_a_topic_leaves_out_its_header() -> None:
    found = resolve('/imu/angular_velocity', TOPICS, classes)
    assert [s.label for s in found] == [
        '/imu/angular_velocity/x',
        '/imu/angular_velocity/y',
        '/imu/angular_velocity/z',
    ]
    assert fields('/voltage') == [('/voltage', 'data', None)]
    whole = [s.field for s in resolve('/range', TOPICS, classes)]
    assert whole == [
        'radiation_type', 'field_of_view', 'min_range', 'max_range', 'range', 'variance'
    ]  # fmt: skip
    stamp = [s.field for s in resolve('/range/header', TOPICS, classes)]
    assert stamp == ['header.stamp.sec', 'header.stamp.nanosec']


def test_elements_of_arrays() -> None:
    assert fields('/joint_states/position[2]') == [('/joint_states', 'position', 2)]
    assert fields('/joint_states/velocity/0') == [('/joint_states', 'velocity', 0)]
    assert fields('/imu/orientation_covariance[8]') == [('/imu', 'orientation_covariance', 8)]


@pytest.mark.parametrize(
    ('address', 'message'),
    [
        ('/imu/orientation_covariance[9]', 'orientation_covariance has 9 elements, not 10'),
        ('/joint_states/position', 'position is an array: plot an element, e.g. '
         '/joint_states/position[0]'),
        ('/joint_states/name[0]', 'name is an array of string'),
        ('/imu/header/frame_id', 'header.frame_id is a string, not a number'),
        ('/imu/linear_acceleration/w', "linear_acceleration has no field 'w' (it has: x, y, z)"),
        ('/voltage/data/x', "data is a number, it has no field 'x'"),
        ('/nothing/x', 'no known topic starts this address'),
        ('imu/angular_velocity/x', 'an address starts with the topic'),
    ],
)  # fmt: skip
def test_addresses_that_name_no_number_say_why(address: str, message: str) -> None:
    with pytest.raises(PlotError) as raised:
        resolve(address, TOPICS, classes)
    assert str(raised.value).startswith(f'{address}: ')
    assert message in str(raised.value)


def test_values_from_messages_and_from_bag_columns() -> None:
    imu = zros.Message('sensor_msgs/msg/Imu')
    imu.linear_acceleration.x = 9.81
    imu.orientation_covariance[4] = 0.5
    (ax,) = resolve('/imu/linear_acceleration/x', TOPICS, classes)
    (cov,) = resolve('/imu/orientation_covariance[4]', TOPICS, classes)
    assert (ax.value(imu), cov.value(imu)) == (9.81, 0.5)
    joints = zros.Message('sensor_msgs/msg/JointState', position=[1.0, 2.0])
    (third,) = resolve('/joint_states/position[2]', TOPICS, classes)
    assert np.isnan(third.value(joints))  # a message with fewer elements: a gap, not an error

    fixed = {'position': np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])}
    assert third.column(fixed).tolist() == [3.0, 6.0]
    ragged = np.empty(2, object)
    ragged[0], ragged[1] = np.array([1.0, 2.0, 3.0]), np.array([4.0])
    assert np.array_equal(third.column({'position': ragged}), [3.0, np.nan], equal_nan=True)
    keyword = Series('/x/from', '/x', 'pkg/msg/T', 'from')
    assert keyword.attributes == ('from_',)


def test_moving_average_is_causal_and_shorter_at_the_start() -> None:
    values = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert moving_average(values, 3).tolist() == [1.0, 1.5, 2.0, 3.0, 4.0, 5.0]
    assert moving_average(values, 1).tolist() == values.tolist()
    gaps = moving_average(np.array([np.nan, 2.0, np.nan, 4.0]), 2)
    assert np.array_equal(gaps, [np.nan, 2.0, 2.0, 4.0], equal_nan=True)
    assert moving_average(np.array([]), 5).size == 0
    with pytest.raises(ValueError, match='length of 1 or more'):
        moving_average(values, 0)
