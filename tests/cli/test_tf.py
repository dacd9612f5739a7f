"""``zros tf echo`` and ``zros tf frames``: from recordings and live, against zros broadcasters."""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from pathlib import Path

import pytest

import zros
from tests.cli.conftest import Cli
from zros.node import Node
from zros.tf import Buffer, StaticTransformBroadcaster, TransformBroadcaster


def stamped(parent: str, child: str, stamp: int, x: float, yaw: float = 0.0) -> zros.cdr.Message:
    t = zros.Message('geometry_msgs/msg/TransformStamped')
    t.header.frame_id, t.child_frame_id = parent, child
    t.header.stamp = zros.Time(stamp).to_msg()
    t.transform.translation.x = x
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return t


def test_echo_from_a_recording_prints_what_tf2_echo_prints(cli: Cli, testdata: Path) -> None:
    bag = testdata / 'ros2' / 'tf_example_db3'
    result = cli.run('tf', 'echo', 'odom', 'base_link', '--bag', str(bag), '--count', '2')
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 20
    buffer = Buffer.from_bag(bag)
    first = int(buffer.stamps('odom', 'base_link')[0])
    t = buffer.lookup_transform('odom', 'base_link', first).transform
    assert lines[0] == f'At time {first // 10**9}.{first % 10**9:09d}'
    assert lines[1] == (
        f'- Translation: [{t.translation.x:.3f}, {t.translation.y:.3f}, {t.translation.z:.3f}]'
    )
    q = t.rotation
    assert (
        lines[2] == f'- Rotation: in Quaternion (xyzw) [{q.x:.3f}, {q.y:.3f}, {q.z:.3f}, {q.w:.3f}]'
    )
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y**2 + q.z**2))
    assert lines[3].startswith('- Rotation: in RPY (radian) [')
    assert lines[3].endswith(f', {yaw:.3f}]')
    assert lines[4].endswith(f', {math.degrees(yaw):.3f}]')
    assert lines[5] == '- Matrix:'
    assert lines[9].split() == ['0.000', '0.000', '0.000', '1.000']
    assert lines[6].split()[3] == f'{t.translation.x:.3f}'
    assert lines[10].startswith('At time ') and lines[10] != lines[0]  # one second later


def test_a_static_chain_and_ros1_broadcasters_as_tf2_tools_print_them(
    cli: Cli, testdata: Path
) -> None:
    bag = testdata / 'ros1' / 'tf_franka.bag'
    result = cli.run('tf', 'echo', 'panda_hand', 'panda_hand_tcp', '--bag', str(bag))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[:2] == ['At time 0.0', '- Translation: [0.000, 0.000, 0.103]']  # tf2_echo's
    result = cli.run('tf', 'frames', '--bag', str(bag))
    assert result.returncode == 0, result.stderr
    # view_frames names the node that sent each frame (the ROS 1 connection's callerid)
    frames = result.stdout
    assert (
        "panda_link0: \n  parent: 'world'\n  broadcaster: '/virtual_joint_broadcaster_0'" in frames
    )
    assert (
        "panda_leftfinger: \n  parent: 'panda_hand'\n  broadcaster: '/robot_state_publisher'"
        in (frames)
    )


def test_echo_unknown_frame_from_a_recording_names_the_closest(cli: Cli, testdata: Path) -> None:
    bag = testdata / 'ros2' / 'tf_example_db3'
    result = cli.run('tf', 'echo', 'odom', 'base_lnk', '--bag', str(bag))
    assert result.returncode == 1
    assert '"base_lnk" passed to lookup_transform argument source_frame' in result.stderr
    assert '"base_link"' in result.stderr


def test_frames_from_a_recording_as_text_and_pictures(
    cli: Cli, testdata: Path, tmp_path: Path
) -> None:
    bag = testdata / 'ros2' / 'tf_franka_db3'
    svg = tmp_path / 'frames.svg'
    result = cli.run('tf', 'frames', '--bag', str(bag), '-o', str(svg))
    assert result.returncode == 0, result.stderr
    assert "panda_link1: \n  parent: 'panda_link0'\n" in result.stdout
    assert "panda_link0: \n  parent: 'world'\n" in result.stdout
    assert f'wrote {svg}' in result.stdout
    picture = svg.read_text()
    assert 'panda_link7' in picture and 'Average rate: 10.' in picture
    png = tmp_path / 'frames.png'
    assert cli.run('tf', 'frames', '--bag', str(bag), '-o', str(png)).returncode == 0
    assert png.read_bytes().startswith(b'\x89PNG')
    empty = cli.run('tf', 'frames', '--bag', str(testdata / 'ros2' / 'talker_mcap'))
    assert empty.returncode == 1 and 'no topic /tf or /tf_static' in empty.stderr


def test_live_echo_and_frames(cli: Cli, zros_node: Callable[..., Node], tmp_path: Path) -> None:
    node = zros_node('robot')
    StaticTransformBroadcaster(node).send_transform(stamped('base_link', 'laser', 0, 0.25))
    broadcaster = TransformBroadcaster(node)
    running = cli.start('tf', 'echo', 'odom', 'laser', '--rate', '20', '--count', '3')
    stamp = 10**9
    line = ''

    def drive() -> None:
        nonlocal stamp
        broadcaster.send_transform(stamped('odom', 'base_link', stamp, 1.0, yaw=math.pi / 2))
        stamp += 10**8

    while not line.startswith('- Translation'):
        drive()
        try:
            line = running.wait_line(lambda text: text.startswith('- Translation'), timeout=0.2)
        except AssertionError as exc:
            if 'the command ended' in str(exc):
                raise
    assert line == '- Translation: [1.000, 0.250, 0.000]'
    assert running.wait_line(lambda text: text.startswith('- Rotation: in RPY (degree)')).endswith(
        ', 90.000]'
    )
    while running.process.poll() is None:
        drive()
        with contextlib.suppress(AssertionError):  # lines until 0.1 s pass or it ends
            running.wait_line(lambda text: False, timeout=0.1)
    assert running.process.returncode == 0

    frames = cli.start('tf', 'frames', '--wait', '2', '-o', str(tmp_path / 'live.pdf'))
    while frames.process.poll() is None:
        drive()
        with contextlib.suppress(AssertionError):
            frames.wait_line(lambda text: False, timeout=0.1)
    assert frames.process.returncode == 0, frames.errors.text()
    seen = frames.seen
    laser = seen.index('laser: ')
    assert seen[laser + 1] == "  parent: 'base_link'"
    assert 'robot' in seen[laser + 2], seen  # the broadcaster: the publishing node
    assert seen[seen.index('base_link: ') + 1] == "  parent: 'odom'"
    assert (tmp_path / 'live.pdf').read_bytes().startswith(b'%PDF')


def test_bad_rate(cli: Cli, testdata: Path) -> None:
    result = cli.run('tf', 'echo', 'a', 'b', '--rate', '0', '--bag', str(testdata))
    assert result.returncode == 1 and '--rate must be above 0' in result.stderr


@pytest.mark.parametrize('verb', ['echo', 'frames', 'monitor'])
def test_help_has_examples(cli: Cli, verb: str) -> None:
    result = cli.run('tf', verb, '--help')
    assert result.returncode == 0 and 'examples: zros tf' in result.stdout


def test_live_monitor_reports_delays_per_frame_and_broadcaster(
    cli: Cli, zros_node: Callable[..., Node]
) -> None:
    """tf2_monitor's report: transforms stamped 0.2 s before they are sent arrive at least
    0.2 s late; the chain's frames, its net delay, and the publishing node by name."""
    import time

    node = zros_node('robot')
    StaticTransformBroadcaster(node).send_transform(stamped('base_link', 'laser', 0, 0.25))
    broadcaster = TransformBroadcaster(node)

    def drive() -> None:
        broadcaster.send_transform(stamped('odom', 'base_link', time.time_ns() - 2 * 10**8, 1.0))

    def report(*args: str) -> list[str]:
        running = cli.start('tf', 'monitor', *args, '--period', '2', '--count', '1')
        while running.process.poll() is None:
            drive()
            with contextlib.suppress(AssertionError):  # lines until 0.05 s pass or it ends
                running.wait_line(lambda text: False, timeout=0.05)
        assert running.process.returncode == 0, running.errors.text()
        return running.seen

    seen = report('odom', 'laser')
    assert seen[:2] == ['RESULTS: for odom to laser', 'Chain is: odom -> base_link -> laser']
    net = seen[2].split()
    assert net[:4] == ['Net', 'delay', 'avg', '='] and 0.2 <= float(net[4].rstrip(':')) < 5
    frames = [line for line in seen if line.startswith('Frame: ')]
    assert frames[0].startswith('Frame: base_link published by ') and 'robot' in frames[0]
    delay = frames[0].split('Average Delay: ')[1].split()
    assert 0.2 <= float(delay[0]) < 5 and float(delay[0]) <= float(delay[3])  # avg <= max
    assert frames[1].startswith('Frame: laser published by ') and frames[1].endswith('(static)')
    broadcasters = seen[seen.index('All Broadcasters:') + 1 :]
    assert any(' Hz, Average Delay: ' in line and 'robot' in line for line in broadcasters)

    everything = report()
    assert everything[0] == 'RESULTS: for all Frames'
    assert sum(line.startswith('Frame: ') for line in everything) == 2


def test_monitor_arguments(cli: Cli) -> None:
    one = cli.run('tf', 'monitor', 'map')
    assert one.returncode == 1 and 'give two frames' in one.stderr
    period = cli.run('tf', 'monitor', '--period', '0')
    assert period.returncode == 1 and '--period must be above 0' in period.stderr
