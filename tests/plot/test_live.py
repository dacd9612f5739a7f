"""Live plots of a known signal: the lines hold exactly what was published, when it was."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import matplotlib.image
import numpy as np
import pytest

import zros
from zros.plot import LivePlot, PlotError, live, moving_average
from zros.testing import spinning, wait_for

Node = Callable[..., Any]
VECTOR = 'geometry_msgs/msg/Vector3'
RATE = 50.0  # Hz


def sine(k: float) -> float:
    """The test signal: 1 Hz sampled at 50 Hz."""
    return math.sin(2 * math.pi * k / RATE)


@pytest.fixture
def signal(zros_node: Node) -> Iterator[Any]:
    """A node publishing ``/signal`` at 50 Hz: x = sample number k, y = sin(2 pi k / 50)."""
    talker = zros_node('signal', enable_rosout=False)
    publisher = talker.create_publisher(VECTOR, '/signal')
    count = [0]

    def tick() -> None:
        k = count[0]
        publisher.write(zros.Message(VECTOR, x=float(k), y=sine(k), z=-1.0))
        count[0] += 1

    talker.create_timer(1 / RATE, tick)
    with spinning(talker):
        yield talker


def test_the_lines_hold_the_published_values(zros_node: Node) -> None:
    talker = zros_node('talker', enable_rosout=False)
    publisher = talker.create_publisher('sensor_msgs/msg/Imu', '/imu')
    plotter = zros_node('plotter', enable_rosout=False)
    values = [0.5, -1.0, 2.0, 4.0, 3.0, 1.5]
    with LivePlot(plotter, ['/imu/linear_acceleration/x'], window=None, filter=3) as plot:
        plot.start()
        assert publisher.wait_for_subscribers()
        for value in values:
            imu = zros.Message('sensor_msgs/msg/Imu')
            imu.linear_acceleration.x = value
            publisher.write(imu)
        assert wait_for(lambda: plot.received == len(values))
        plot.stop()
        plot.update()
        axes = plot.figure.axes[0]
        raw, smooth = axes.lines
        assert raw.get_ydata().tolist() == values
        assert np.allclose(smooth.get_ydata(), moving_average(np.array(values), 3))
        times = np.asarray(raw.get_xdata())
        assert (np.diff(times) >= 0).all() and 0 <= times[0] <= times[-1] <= plot.elapsed()
        assert [t.get_text() for t in axes.get_legend().get_texts()] == [
            '/imu/linear_acceleration/x',
            '/imu/linear_acceleration/x, moving average of 3',
        ]
        assert axes.get_title() == '/imu'
        assert axes.get_xlabel() == 'time since the start [s]'
        assert axes.get_ylabel() == '/imu/linear_acceleration/x'
        start, end = axes.get_xlim()
        assert start == 0.0 and times[-1] <= end <= max(1.0, plot.elapsed())  # window=None: all
        low, high = axes.get_ylim()
        assert low < -1.0 and high > 4.0 and high - low < 5.0 * 1.2  # the data, a 5 % margin
        assert (plot.stats[0].count, plot.stats[0].minimum, plot.stats[0].maximum) == (6, -1.0, 4.0)


def test_a_sine_at_50_hz_scrolls_through_the_window(
    signal: Any, zros_node: Node, tmp_path: Path
) -> None:
    plotter = zros_node('plotter', enable_rosout=False)
    figure = live(
        ['/signal/y', '/signal/x'],
        node=plotter,
        window=1.0,
        count=100,
        png=tmp_path / 'sine.png',
        frames_dir=tmp_path / 'frames',
        interval=0.25,
    )
    axes = figure.axes[0]
    assert [line.get_label() for line in axes.lines] == ['/signal/y', '/signal/x']
    y_line, x_line = axes.lines
    k = np.asarray(x_line.get_ydata())
    y = np.asarray(y_line.get_ydata())
    times = np.asarray(y_line.get_xdata())
    # consecutive samples, each with its value: nothing lost, reordered or mixed up (the window
    # holds the last second's, some 50; a loaded machine delays the publisher's timer: 39 seen)
    assert len(k) >= 20 and (np.diff(k) == 1).all()
    assert np.allclose(y, np.sin(2 * np.pi * k / RATE))
    assert np.array_equal(times, np.asarray(x_line.get_xdata()))
    # stamped on arrival: 20 ms apart, give or take a busy machine
    assert 0.014 < float(np.median(np.diff(times))) < 0.026
    start, end = axes.get_xlim()
    assert end - start == pytest.approx(1.0)
    assert times[-1] <= end and times[0] < start  # the line enters from the left edge
    assert times[1] >= start  # and older values were dropped
    assert abs(end - times[-1]) < 0.5  # the window ends now
    frames = sorted((tmp_path / 'frames').glob('frame_*.png'))
    assert len(frames) >= 2
    assert frames[0].name == 'frame_00000.png'
    picture = matplotlib.image.imread(tmp_path / 'sine.png')
    assert picture.shape[:2] == (450, 800)  # 8 x 4.5 inches at 100 dpi
    blue = np.array(matplotlib.colors.to_rgb('C0'))
    assert (np.abs(picture[:, :, :3] - blue).sum(axis=2) < 0.05).sum() > 200  # the sine is drawn


def test_a_window_of_everything_and_a_duration(signal: Any, zros_node: Node) -> None:
    plotter = zros_node('plotter', enable_rosout=False)
    figure = live(['/signal'], node=plotter, window=None, duration=0.6)
    axes = figure.axes[0]
    assert [line.get_label() for line in axes.lines] == ['/signal/x', '/signal/y', '/signal/z']
    assert axes.get_xlim()[0] == 0.0
    z = np.asarray(axes.lines[2].get_ydata())
    assert z.size >= 10 and (z == -1.0).all()
    assert axes.get_ylabel() == 'value'


def test_an_absent_topic_is_an_error(zros_node: Node) -> None:
    plotter = zros_node('plotter', enable_rosout=False)
    with pytest.raises(
        PlotError, match=r'^/nothing/x: no topic on the network starts this address'
    ):
        live(['/nothing/x'], node=plotter, wait=0.2, duration=1)
