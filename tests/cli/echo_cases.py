"""Messages whose ``ros2 topic echo`` text is kept in ``golden/`` (see golden/SOURCES.md)."""

from __future__ import annotations

import math
from typing import Any

#: name -> (type, fields, options of message_to_yaml / message_to_csv)
CASES: dict[str, tuple[str, dict[str, Any], dict[str, Any]]] = {
    'imu': (
        'sensor_msgs/msg/Imu',
        {
            'header': {'stamp': {'sec': 1700000000, 'nanosec': 123456789}, 'frame_id': 'imu_link'},
            'orientation': {'x': 0.0, 'y': 0.0, 'z': 0.7071067811865476, 'w': 0.7071067811865476},
            'orientation_covariance': [1e-05, 0.0, 0.0, 0.0, 1e-05, 0.0, 0.0, 0.0, -0.0],
            'angular_velocity': {'x': 0.01, 'y': -0.02, 'z': 1e20},
            'linear_acceleration': {'x': 0.1, 'y': 9.81, 'z': -1234.5},
        },
        {},
    ),
    'scan': (
        'sensor_msgs/msg/LaserScan',
        {
            'header': {'frame_id': 'laser'},
            'angle_min': -1.5,
            'angle_increment': 0.1,
            'range_max': 30.0,
            'ranges': [0.1, 1.0, math.inf, 2.5],
            'intensities': [],
        },
        {},
    ),
    'scan_no_arr': ('sensor_msgs/msg/LaserScan', {'ranges': [1.0, 2.0]}, {'no_arr': True}),
    'scan_truncated': (
        'sensor_msgs/msg/LaserScan',
        {'header': {'frame_id': 'a_long_frame'}, 'ranges': [1.0, 2.0, 3.0, 4.0]},
        {'truncate_length': 2},
    ),
    'strings': (
        'test_msgs/msg/Strings',
        {
            'string_value': 'yes',
            'bounded_string_value': 'a\nb',
            'string_value_default1': 'héllo ✓',
            'string_value_default2': "it's",
            'string_value_default3': '',
            'string_value_default4': '123',
            'string_value_default5': 'null',
        },
        {},
    ),
    'strings_no_str': ('test_msgs/msg/Strings', {'string_value': 'hello'}, {'no_str': True}),
    'basic_types': (
        'test_msgs/msg/BasicTypes',
        {
            'bool_value': True,
            'byte_value': 255,
            'char_value': 65,
            'float32_value': 0.1,
            'float64_value': -2.5e-10,
            'int8_value': -128,
            'uint8_value': 255,
            'int16_value': -32768,
            'uint16_value': 65535,
            'int32_value': -2147483648,
            'uint32_value': 4294967295,
            'int64_value': -9223372036854775808,
            'uint64_value': 18446744073709551615,
        },
        {},
    ),
    'bytes': (
        'std_msgs/msg/UInt8MultiArray',
        {
            'layout': {'dim': [{'label': 'row', 'size': 3, 'stride': 3}], 'data_offset': 0},
            'data': bytes([0, 255, 7]),
        },
        {},
    ),
    'pose_array': (
        'geometry_msgs/msg/PoseArray',
        {
            'header': {'frame_id': 'map'},
            'poses': [
                {'position': {'x': 1.0, 'y': 2.0}},
                {'position': {'z': -3.0}, 'orientation': {'w': 0.5}},
            ],
        },
        {},
    ),
    'pose_array_flow': (
        'geometry_msgs/msg/PoseArray',
        {'poses': [{'position': {'x': 1.0}}]},
        {'flow_style': True},
    ),
    'arrays': (
        'test_msgs/msg/Arrays',
        {
            'bool_values': [True, False, True],
            'float64_values': [1.5, -0.0, 1e-300],
            'string_values': ['', 'max value', 'min value'],
            'int8_values': [-1, 0, 1],
        },
        {},
    ),
    'arrays_no_arr': ('test_msgs/msg/Arrays', {}, {'no_arr': True}),
    'bounded_no_arr': ('test_msgs/msg/BoundedSequences', {'int32_values': [5]}, {'no_arr': True}),
}

CSV_CASES = ('imu', 'basic_types', 'scan', 'scan_no_arr', 'bytes', 'arrays', 'strings_no_str')
