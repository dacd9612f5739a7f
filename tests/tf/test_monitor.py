"""zros tf monitor's tables (tf2_monitor's): delays per frame and broadcaster, bounded."""

from __future__ import annotations

import zros
from zros.cdr import Message
from zros.tf.edge_tree import MAX_FRAMES
from zros.tf.monitor import WINDOW, DelayMonitor

S = 10**9


def tf_message(*frames: tuple[str, int]) -> Message:
    message = zros.Message('tf2_msgs/msg/TFMessage')
    for child, stamp in frames:
        t = zros.Message('geometry_msgs/msg/TransformStamped')
        t.header.frame_id, t.child_frame_id = 'odom', child
        t.header.stamp = zros.Time(stamp).to_msg()
        t.transform.rotation.w = 1.0
        message.transforms.append(t)
    return message


def test_delays_per_frame_broadcaster_and_chain() -> None:
    now = [10 * S]
    monitor = DelayMonitor(now=lambda: now[0])
    monitor.record(tf_message(('base', 10 * S - S // 10), ('wheel', 10 * S - S // 2)), 'rsp', False)
    now[0] = 11 * S
    monitor.record(tf_message(('base', 11 * S - S // 10 * 3)), 'rsp', False)
    monitor.record(tf_message(('laser', 0)), 'urdf', True)
    monitor.sample_chain(11 * S - S // 4)
    monitor.sample_chain(0)  # a static chain: no delay to take
    lines = monitor.report(['wheel', 'base', 'odom']).splitlines()
    assert lines[:9] == [
        'RESULTS: for odom to wheel',
        'Chain is: odom -> base -> wheel',
        'Net delay     avg = 0.25: max = 0.25',
        '',
        'Frames:',
        'Frame: base published by rsp Average Delay: 0.2 Max Delay: 0.3',
        'Frame: wheel published by rsp Average Delay: 0.5 Max Delay: 0.5',
        '',
        'All Broadcasters:',
    ]
    # per message: the average of its transforms' delays, (0.1 + 0.5) / 2 then 0.3
    assert lines[9].startswith('Node: rsp ') and lines[9].endswith(
        ' Hz, Average Delay: 0.3 Max Delay: 0.3'
    )
    assert lines[10:] == ['Node: urdf static']
    everything = monitor.report().splitlines()
    assert everything[0] == 'RESULTS: for all Frames'
    assert 'Frame: laser published by urdf (static)' in everything


def test_a_flood_of_frames_and_values_is_bounded() -> None:
    monitor = DelayMonitor(now=lambda: 5 * S)
    for number in range(MAX_FRAMES + 500):
        monitor.record(tf_message((f'f{number}', S)), f'sender{number}', False)
    for _ in range(WINDOW + 10):
        monitor.record(tf_message(('f0', 4 * S)), 'sender0', False)
    lines = monitor.report().splitlines()
    assert sum(line.startswith('Frame: ') for line in lines) == MAX_FRAMES
    assert sum(line.startswith('Node: ') for line in lines) == MAX_FRAMES
    assert 'Frame: f0 published by sender0 Average Delay: 1 Max Delay: 1' in lines
