"""``zros plot`` and ``zros graph`` through the console script, against a router in the test."""

from __future__ import annotations

import re
import signal as signal_module
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib.image
import numpy as np
import pytest

from tests.plot.conftest import Cli
from tests.plot.fake_bridge import FakeBridge
from tests.plot.test_bag import COUNT, make_bag, speed
from tests.plot.test_live import signal
from zros.keyexpr.kinds import EntityKind
from zros.testing import wait_for

Node = Callable[..., Any]
__all__ = ['signal']  # the fixture publishing /signal at 50 Hz


def drawn(path: Path, color: str) -> int:
    """How many pixels of the picture have ``color``."""
    picture = matplotlib.image.imread(path)[:, :, :3]
    target = np.array(matplotlib.colors.to_rgb(color))
    return int((np.abs(picture - target).sum(axis=2) < 0.05).sum())


def test_plot_live_into_a_png(cli: Cli, signal: Any, tmp_path: Path) -> None:
    png = tmp_path / 'signal.png'
    result = cli.run('plot', '/signal/y', '/signal/x', '--count', '50', '--filter', '5',
                     '--png', str(png))  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[:2] == [
        'plotting /signal/y [geometry_msgs/msg/Vector3]',
        'plotting /signal/x [geometry_msgs/msg/Vector3]',
    ]
    assert lines[-1] == f'wrote {png}'
    summary = re.fullmatch(r'/signal/y: (\d+) values, min (\S+), max (\S+)', lines[-3])
    assert summary is not None, lines
    count, low, high = int(summary[1]), float(summary[2]), float(summary[3])
    assert 50 <= count <= 60  # stops at 50 messages (a few more may land meanwhile)
    assert -1.0 <= low < -0.9 and 0.9 < high <= 1.0  # a second of the 1 Hz sine
    samples = re.fullmatch(r'/signal/x: (\d+) values, min (\S+), max (\S+)', lines[-2])
    assert samples is not None and int(samples[1]) == count
    assert float(samples[3]) - float(samples[2]) == count - 1  # consecutive sample numbers
    assert matplotlib.image.imread(png).shape[:2] == (450, 800)
    assert drawn(png, 'C0') > 100 and drawn(png, 'C1') > 100  # both averages are drawn


def test_plot_live_frames_and_an_absent_topic(cli: Cli, signal: Any, tmp_path: Path) -> None:
    frames = tmp_path / 'frames'
    result = cli.run('plot', '/signal', '--duration', '1.2', '--frames', str(frames),
                     '--interval', '0.3', '--window', '0.5')  # fmt: skip
    assert result.returncode == 0, result.stderr
    written = sorted(frames.glob('frame_*.png'))
    assert result.stdout.splitlines()[-1] == f'wrote {len(written)} frames into {frames}'
    assert 3 <= len(written) <= 7  # one every 0.3 s for 1.2 s, and the last
    assert drawn(written[-1], 'C0') > 100 and drawn(written[-1], 'C1') > 100  # x and y
    absent = cli.run('plot', '/nothing/x', '--wait', '0.2', '--png', str(tmp_path / 'x.png'))
    assert absent.returncode == 1
    assert absent.stderr == (
        'zros: error: /nothing/x: no topic on the network starts this address (waited 0.2 s; '
        'zros topic list shows the topics)\n'
    )


def test_plot_live_until_ctrl_c(cli: Cli, signal: Any, tmp_path: Path) -> None:
    png, frames = tmp_path / 'stopped.png', tmp_path / 'frames'
    running = cli.start('plot', '/signal/y', '--png', str(png), '--frames', str(frames),
                        '--interval', '0.2')  # fmt: skip
    running.wait_line(lambda line: line == 'Ctrl-C to stop')
    assert wait_for(lambda: len(list(frames.glob('*.png'))) >= 3, timeout=20)  # data came
    running.process.send_signal(signal_module.SIGINT)
    code, rest = running.finish()
    assert code == 0, running.errors.text()
    summary, wrote_png, wrote_frames = rest.splitlines()
    values = re.fullmatch(r'/signal/y: (\d+) values, min \S+, max \S+', summary)
    assert values is not None and int(values[1]) >= 10
    assert wrote_png == f'wrote {png}'
    assert wrote_frames.startswith('wrote ') and wrote_frames.endswith(f' frames into {frames}')
    assert drawn(png, 'C0') > 100


def test_plot_a_bag(cli: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bag = make_bag(tmp_path / 'run1')
    png = tmp_path / 'speed.png'
    result = cli.run('plot', str(bag), '/odom/twist/twist/linear/x', '--png', str(png))
    assert result.returncode == 0, result.stderr
    values = [speed(n) for n in range(COUNT)]
    assert result.stdout.splitlines() == [
        f'/odom/twist/twist/linear/x: {COUNT} values from 0.500 s to 4.400 s, '
        f'min {min(values):.6g}, max {max(values):.6g}',
        f'wrote {png}',
    ]
    assert drawn(png, 'C0') > 200
    # no display and no --png: a file in the working folder, and a word about it
    monkeypatch.setenv('MPLBACKEND', 'Agg')
    monkeypatch.chdir(tmp_path)
    quiet = cli.run('plot', str(bag), '/joint_states/position[0]', '--start', '1', '--end', '2')
    assert quiet.returncode == 0, quiet.stderr
    assert quiet.stdout.splitlines() == [
        'no display: the plot goes into zros_plot.png (--png FILE to choose)',
        '/joint_states/position[0]: 4 values from 1.000 s to 1.750 s, min 4, max 7',
        'wrote zros_plot.png',
    ]
    assert (tmp_path / 'zros_plot.png').is_file()
    wrong = cli.run('plot', str(bag), '/odom/twist/twist/linear/x', '--frames', 'f')
    assert (wrong.returncode, wrong.stderr) == (
        1,
        'zros: error: --frames is for live plots, not recordings\n',
    )


def test_a_missing_bag_is_said_at_once(
    cli: Cli, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # --wait 60: had any of these been taken for a live topic, the command would wait a minute
    monkeypatch.chdir(tmp_path)
    absolute = str(tmp_path / 'run9')  # a mistyped absolute path: its folder exists
    for argument in ('no_such_bag', './run9', '~/no_such_bag', 'run9.mcap', '/no/run9.mcap',
                     absolute):  # fmt: skip
        started = time.monotonic()
        result = cli.run('plot', argument, '/x/data', '--wait', '60', timeout=50)
        assert time.monotonic() - started < 30
        assert result.returncode == 2, (argument, result.stderr)
        assert result.stderr.startswith(f'zros: error: no such file or folder: {argument}')
        assert result.stdout == ''
    hint = cli.run('plot', 'no_such_bag', '/x/data', '--wait', '60', timeout=50).stderr
    assert hint.endswith('(a topic address starts with /)\n')
    # the other way: a relative bag that exists plots from it, an address waits for its topic
    make_bag(tmp_path / 'run1')
    found = cli.run('plot', 'run1', '/odom/twist/twist/linear/x', '--png', 'odom.png')
    assert found.returncode == 0, found.stderr
    assert found.stdout.splitlines()[-1] == 'wrote odom.png'
    live = cli.run('plot', '/run1/x', '--wait', '0.2', '--png', 'x.png')
    assert live.returncode == 1
    assert 'no topic on the network starts this address (waited 0.2 s' in live.stderr


def test_which_first_arguments_name_files(tmp_path: Path) -> None:
    from zros.cli.verbs.plot import names_a_path

    paths = ['run1', 'run1/', './run1', '../bags/run1', '~/bags/x.mcap', 'x.db3', '/d/x.MCAP',
             '/data/run.bag']  # fmt: skip
    addresses = ['/odom/twist/twist/linear/x', '/x/data', '/scan/ranges[0]', '/run1']
    assert [names_a_path(p) for p in paths] == [True] * len(paths)
    assert [names_a_path(a) for a in addresses] == [False] * len(addresses)
    # an absolute path whose folder exists; a top-level folder (a topic /tmp, field x) does not
    assert names_a_path(str(tmp_path / 'run1'))
    assert not names_a_path('/tmp/x')
    assert not names_a_path(str(tmp_path / 'nope' / 'x'))


def test_graph_picture_and_dot(
    cli: Cli, zros_node: Node, zros_transport: Any, tmp_path: Path
) -> None:
    bridge = FakeBridge(
        zros_transport(), [(EntityKind.PUBLISHER, '/turtle1/pose', 'turtlesim/msg/Pose')]
    )
    try:
        follower = zros_node('follower')
        follower.create_subscription('geometry_msgs/msg/Pose2D', '/turtle1/pose', lambda m: None)
        follower.create_publisher('geometry_msgs/msg/Twist', '/turtle1/cmd_vel')
        dot = tmp_path / 'graph.dot'
        result = cli.run('graph', '-o', str(dot))
        assert result.returncode == 0, result.stderr
        assert result.stdout == f'2 nodes, 2 topics, 3 edges -> {dot}\n'
        assert dot.read_text().splitlines()[3:] == [
            '  "n:/follower" [label="/follower", shape=ellipse];',
            '  "n:/zenoh_bridge_ros2dds" [label="/zenoh_bridge_ros2dds", shape=ellipse];',
            '  "t:/turtle1/cmd_vel" [label="/turtle1/cmd_vel", shape=box];',
            '  "t:/turtle1/pose" [label="/turtle1/pose", shape=box];',
            '  "n:/follower" -> "t:/turtle1/cmd_vel";',
            '  "n:/zenoh_bridge_ros2dds" -> "t:/turtle1/pose";',
            '  "t:/turtle1/pose" -> "n:/follower";',
            '}',
        ]
        svg = tmp_path / 'graph.svg'
        assert cli.run('graph', '-o', str(svg)).returncode == 0
        texts = re.findall(r'>(/[\w/]+)</text>', svg.read_text())
        assert sorted(texts) == [
            '/follower', '/turtle1/cmd_vel', '/turtle1/pose', '/zenoh_bridge_ros2dds'
        ]  # fmt: skip
        png = tmp_path / 'graph.png'
        everything = cli.run('graph', '-o', str(png), '--no-hide-debug')
        assert everything.returncode == 0, everything.stderr
        # /parameter_events from the follower
        assert everything.stdout == f'2 nodes, 3 topics, 4 edges -> {png}\n'
        assert drawn(png, '#e6eef8') > 500 and drawn(png, '#fcefdc') > 500  # node, bridge
    finally:
        bridge.close()
