"""``zros demo``: the rosR tutorial from end to end, and the pieces it is made of."""

from __future__ import annotations

import os
import re
import shutil
import struct
import subprocess
import sys
import time
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import zros
from zros.demo import sensor
from zros.demo.analysis import Calibration, RangeNode, fit_curve, moving_average, read_calibration
from zros.demo.sensor import (
    CALIBRATION_TOPIC,
    DISTANCE_TOPIC,
    MAX_RANGE,
    MIN_RANGE,
    PAIRS,
    READINGS,
    VOLTAGE_TOPIC,
)
from zros.demo.tutorial_bag import BAG_NAME, bag_problem, ensure_bag, write_bag
from zros.testing import wait_for

ROOT = Path(__file__).resolve().parents[2]
ZROS = shutil.which('zros', path=str(Path(sys.executable).parent))
PAPER = {'0.8': 0.164, '2.0': 0.061}


def run_demo(*args: str, cwd: Path, env: dict[str, str] | None = None) -> tuple[str, str, float]:
    """Run the installed console script as a user does; returns stdout, stderr, seconds."""
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    started = time.monotonic()
    result = subprocess.run(
        [ZROS, 'demo', *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=cwd,
        env=env,
    )
    seconds = time.monotonic() - started
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout, result.stderr, seconds


def png_size(path: Path) -> tuple[int, int]:
    """Width and height from a PNG's header."""
    data = path.read_bytes()
    assert data.startswith(b'\x89PNG\r\n\x1a\n') and data[12:16] == b'IHDR'
    width, height = struct.unpack('>II', data[16:24])
    return width, height


def check_report(stdout: str, output: Path) -> None:
    """The report's counts, fitted distances and plots."""
    assert '314 voltages played, 314 received by R_demo' in stdout
    assert '240 calibration pairs read from the bag (240 of 240 played also seen' in stdout
    assert f'314 sensor_msgs/Range published on {DISTANCE_TOPIC}, 314 received' in stdout
    fitted = dict(re.findall(r'(\d\.\d) V -> (\d\.\d+) m \(the paper', stdout))
    assert fitted.keys() == PAPER.keys()
    for volt, paper in PAPER.items():
        assert float(fitted[volt]) == pytest.approx(paper, rel=0.1)
    rms = re.search(r'residual error (\d+\.\d+) mm RMS', stdout)
    assert rms is not None and 0.5 < float(rms.group(1)) < 10
    assert 'router   in this process, at tcp/127.0.0.1:' in stdout
    assert 'NOT OK' not in stdout
    sizes = {'voltage.png': (800, 400), 'fit.png': (700, 550), 'distance.png': (800, 440)}
    for name, size in sizes.items():
        assert png_size(output / name) == size
        assert f'{output.name}/{name}' in stdout


def test_console_script_runs_the_tutorial_and_reuses_its_bag(tmp_path: Path) -> None:
    stdout, stderr, seconds = run_demo('--output', 'out', cwd=tmp_path)
    output = tmp_path / 'out'
    assert f'bag      out/{BAG_NAME} (made now): 240 calibration pairs, 314 voltages' in stdout
    check_report(stdout, output)
    assert seconds < 30, stdout
    # demo0: the voltages are logged (console and /rosout), every 50th at INFO
    logged = re.findall(r'\[R_demo\]: Measured voltage \d\.\d+ V \(reading (\d+)\)', stderr)
    assert logged == [str(n) for n in range(1, READINGS + 1, 50)]
    bag = output / BAG_NAME
    assert sorted(p.name for p in bag.iterdir()) == ['metadata.yaml', f'{BAG_NAME}_0.mcap']
    stamps = {p.name: p.stat().st_mtime_ns for p in bag.iterdir()}

    stdout, _, seconds = run_demo('--output', str(output), cwd=tmp_path)
    assert '(made before, reused)' in stdout
    assert {p.name: p.stat().st_mtime_ns for p in bag.iterdir()} == stamps
    check_report(stdout, output)
    assert seconds < 30, stdout


def test_gui_draws_live_in_a_window(tmp_path: Path) -> None:
    # a stand-in for a window toolkit, so that the --gui code runs where there is no display
    (tmp_path / 'window_backend.py').write_text(
        'from matplotlib.backend_bases import FigureManagerBase\n'
        'from matplotlib.backends.backend_agg import FigureCanvasAgg\n'
        'class FigureCanvas(FigureCanvasAgg):\n'
        '    manager_class = FigureManagerBase\n'
        'FigureManager = FigureManagerBase\n'
        'shown = []\n'
        'def show(*args, **kwargs):\n'
        '    print("windows shown")\n'
    )
    env = {
        **os.environ,
        'MPLBACKEND': 'module://window_backend',
        'PYTHONPATH': str(tmp_path),
    }
    stdout, _, _ = run_demo(
        '--gui', '--output', 'out', '--log-every', '1000', cwd=tmp_path, env=env
    )
    assert 'no display here' not in stdout
    assert stdout.rstrip().endswith('close the windows to end\nwindows shown')
    check_report(stdout, tmp_path / 'out')


# --- the sensor and its bag -------------------------------------------------------------------


def test_the_model_matches_the_paper_and_the_datasheet() -> None:
    for volt, distance in sensor.PAPER_FIT.items():
        assert sensor.voltage_at(distance) == pytest.approx(volt, abs=0.01)
    assert sensor.voltage_at(0.04) == pytest.approx(2.95, abs=0.05)
    assert sensor.voltage_at(0.30) == pytest.approx(0.47, abs=0.02)
    readings = sensor.readings()
    assert len(readings) == READINGS and readings == sensor.readings()  # the same every time
    distances = [d for d, _ in readings]
    assert 0.049 < min(distances) < 0.051 and 0.289 < max(distances) < 0.291
    # 10-bit converter: every voltage is a whole number of steps
    assert all(abs(v / sensor.ADC_STEP - round(v / sensor.ADC_STEP)) < 1e-9 for _, v in readings)
    noise = np.array([v - sensor.voltage_at(d) for d, v in readings])
    assert 0.015 < noise.std() < 0.025
    pairs = sensor.calibration_pairs()
    assert len(pairs) == PAIRS and pairs[0][0] == pytest.approx(MIN_RANGE, abs=0.002)
    assert pairs[-1][0] == pytest.approx(MAX_RANGE, abs=0.002)


def test_the_linearization_type_ships_inside_the_package() -> None:
    shipped = resources.files('zros.demo') / 'msg' / 'Linearization.msg'
    text = shipped.read_text()
    assert sensor.linearization_definition() == text
    # the examples' copy, in the layout of a ROS package, says the same
    example = ROOT / 'examples/interfaces/rosR_demos/msg/Linearization.msg'
    assert example.read_text() == text
    # and `pip install .` (not only an editable install) puts it in the wheel
    tomllib = pytest.importorskip('tomllib')  # Python 3.11 on
    setuptools = tomllib.loads((ROOT / 'pyproject.toml').read_text())['tool']['setuptools']
    shipped_files = {
        p for pattern in setuptools['package-data']['zros'] for p in (ROOT / 'zros').glob(pattern)
    }
    assert ROOT / 'zros/demo/msg/Linearization.msg' in shipped_files
    sensor.register_linearization()
    message = zros.Message(sensor.LINEARIZATION, dist=0.1, volt=1.2)
    assert message.get_fields_and_field_types() == {'dist': 'float32', 'volt': 'float32'}


def test_the_bag_is_deterministic_and_a_real_rosbag2(tmp_path: Path) -> None:
    first = write_bag(tmp_path / 'a' / BAG_NAME)
    second = write_bag(tmp_path / 'b' / BAG_NAME)
    for name in ('metadata.yaml', f'{BAG_NAME}_0.mcap'):
        assert (first / name).read_bytes() == (second / name).read_bytes()
    assert bag_problem(first) is None

    from rosbags.rosbag2 import Reader  # an independent reader

    with Reader(first) as reader:
        topics = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
        assert topics == {
            CALIBRATION_TOPIC: ('rosR_demos/msg/Linearization', PAIRS),
            VOLTAGE_TOPIC: ('std_msgs/msg/Float32', READINGS),
        }
        assert reader.duration == pytest.approx(18.3e9, rel=0.01)
        assert reader.start_time == 1_370_088_000 * 10**9

    with zros.bag.Bag(first) as bag:
        volts = bag.columns(VOLTAGE_TOPIC, ['data'])
    expected = np.array([v for _, v in sensor.readings()], dtype=np.float32)
    assert np.array_equal(volts['data'], expected)
    assert np.all(np.diff(volts['time']) == 40_000_000)  # 25 readings a second


def test_a_broken_bag_is_made_again_and_a_foreign_folder_left_alone(tmp_path: Path) -> None:
    path, made = ensure_bag(tmp_path)
    assert made and path == tmp_path / BAG_NAME
    assert ensure_bag(tmp_path) == (path, False)
    (path / f'{BAG_NAME}_0.mcap').unlink()  # an interrupted copy, say
    assert bag_problem(path) is not None
    assert ensure_bag(tmp_path) == (path, True)
    assert bag_problem(path) is None
    assert ensure_bag(tmp_path, regenerate=True) == (path, True)
    assert [p.name for p in tmp_path.iterdir()] == [BAG_NAME]  # no staging folder left

    (path / 'metadata.yaml').unlink()
    (path / 'notes.txt').write_text('mine')
    with pytest.raises(zros.ZrosError, match='holds more than a bag'):
        ensure_bag(tmp_path)
    assert (path / 'notes.txt').read_text() == 'mine'


# --- the analysis -----------------------------------------------------------------------------


def test_moving_average_and_fit() -> None:
    values = np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    expected = [np.mean(values[max(0, i - 4) : i + 1]) for i in range(len(values))]
    assert np.allclose(moving_average(values, 5), expected)
    pairs = np.array(sensor.calibration_pairs())
    curve = fit_curve(pairs[:, 1], pairs[:, 0])
    assert curve.degree() == 8
    assert curve(0.8) == pytest.approx(0.164, rel=0.1)
    assert curve(2.0) == pytest.approx(0.061, rel=0.1)


def test_calibration_from_the_bag_clamps_to_the_sensor_range(tmp_path: Path) -> None:
    path, _ = ensure_bag(tmp_path)
    calibration = read_calibration(path)
    assert len(calibration.volt) == PAIRS
    assert 0.0005 < calibration.rms_error < 0.01
    assert calibration.distance(0.8) == pytest.approx(0.164, rel=0.1)
    assert calibration.distance(10.0) == pytest.approx(MIN_RANGE, abs=0.003)
    assert calibration.distance(0.0) == pytest.approx(MAX_RANGE, abs=0.01)
    for volt in np.linspace(0, 5, 101):
        assert MIN_RANGE <= calibration.distance(float(volt)) <= MAX_RANGE


def test_range_node_publishes_sensor_msgs_range(zros_node) -> None:  # type: ignore[no-untyped-def]
    pairs = np.array(sensor.calibration_pairs())
    calibration = Calibration(pairs[:, 1], pairs[:, 0], fit_curve(pairs[:, 1], pairs[:, 0]))
    analysis = RangeNode(zros_node('R_demo'), calibration, log_every=1000)
    robot = zros_node('sharpGP2D120')
    echo = zros_node('echo').create_subscription(
        'sensor_msgs/msg/Range', DISTANCE_TOPIC, qos='keep_all'
    )
    voltage = robot.create_publisher('std_msgs/msg/Float32', VOLTAGE_TOPIC)
    assert voltage.wait_for_subscribers() and analysis.publisher.wait_for_subscribers()
    for volt in (0.8, 0.8, 0.8, 2.0):
        voltage.write(zros.Message('std_msgs/msg/Float32', data=volt))
    handled = 0

    def four_handled() -> bool:
        nonlocal handled
        handled += analysis.handle()
        return handled == 4

    assert wait_for(four_handled)
    assert wait_for(lambda: echo.received == 4)
    ranges = echo.take()
    assert analysis.filtered == pytest.approx([0.8, 0.8, 0.8, 1.1])
    first = ranges[0]
    assert first.range == pytest.approx(0.164, rel=0.1)
    assert ranges[3].range == pytest.approx(calibration.distance(1.1), rel=1e-6)
    assert first.header.frame_id == 'sharpGP2D120'
    assert first.radiation_type == 1  # INFRARED
    assert first.field_of_view == pytest.approx(sensor.FIELD_OF_VIEW)
    assert (first.min_range, first.max_range) == pytest.approx((MIN_RANGE, MAX_RANGE))
    stamp = first.header.stamp.sec + first.header.stamp.nanosec / 1e9
    assert stamp == pytest.approx(time.time(), abs=60)


# --- the figures, on the Agg canvas -----------------------------------------------------------


def test_figures_show_what_they_say(tmp_path: Path) -> None:
    from zros.demo.figures import distance_figure, fit_figure, save, voltage_figure

    volts = [v for _, v in sensor.readings()]
    times = [0.04 * n for n in range(len(volts))]  # the bag's 25 readings a second
    figure = voltage_figure(times, volts)
    (axes,) = figure.axes
    assert figure.canvas.__class__.__name__ == 'FigureCanvasAgg'
    assert (axes.get_xlabel(), axes.get_ylabel(), axes.get_title()) == (
        'time [s]',
        'voltage [V]',
        VOLTAGE_TOPIC,
    )
    raw, filtered = axes.lines
    assert np.array_equal(raw.get_ydata(), volts)
    assert np.array_equal(raw.get_xdata(), times) and np.array_equal(filtered.get_xdata(), times)
    assert np.allclose(filtered.get_ydata(), moving_average(np.array(volts)))
    assert [t.get_text() for t in axes.get_legend().get_texts()] == [
        'measured',
        'moving average of 5',
    ]
    assert axes.get_ylim()[0] < min(volts) and axes.get_ylim()[1] > max(volts)  # autoscaled

    pairs = np.array(sensor.calibration_pairs())
    calibration = Calibration(pairs[:, 1], pairs[:, 0], fit_curve(pairs[:, 1], pairs[:, 0]))
    figure = fit_figure(calibration)
    top, bottom = figure.axes
    points, curve, paper = top.lines
    assert len(points.get_xdata()) == PAIRS
    assert np.allclose(curve.get_ydata(), calibration.curve(curve.get_xdata()))
    assert list(paper.get_xdata()) == [0.8, 2.0] and list(paper.get_ydata()) == [0.164, 0.061]
    assert 'poly(volt, 8)' in curve.get_label()
    assert (top.get_ylabel(), bottom.get_xlabel(), bottom.get_ylabel()) == (
        'distance [m]',
        'voltage [V]',
        'residual [mm]',
    )
    assert np.allclose(bottom.lines[0].get_ydata(), 1000 * calibration.residuals)

    ranges = [calibration.distance(v) for v in moving_average(np.array(volts))]
    figure = distance_figure(times, ranges, sensor.sweep())
    (axes,) = figure.axes
    truth, received, low, high = axes.lines
    assert np.array_equal(received.get_ydata(), ranges)
    assert np.array_equal(received.get_xdata(), times) and axes.get_xlabel() == 'time [s]'
    (caption,) = figure.texts  # why the ranges trail the object
    assert caption.get_text() == (
        'Each range comes from the moving average of the last 5 voltages, so it trails the '
        'object by about 2 readings (0.08 s).'
    )
    assert received.get_label() == 'sensor_msgs/Range received'
    assert list(low.get_ydata()) == [MIN_RANGE] * 2 and list(high.get_ydata()) == [MAX_RANGE] * 2
    assert np.sqrt(np.mean((np.array(ranges) - truth.get_ydata()) ** 2)) < 0.02
    assert (axes.get_ylabel(), axes.get_title()) == ('range [m]', DISTANCE_TOPIC)
    assert png_size(Path(save(figure, tmp_path / 'd.png'))) == (800, 440)


def test_figures_need_no_pyplot() -> None:
    code = (
        'import sys\n'
        'from zros.demo import figures, sensor\n'
        'figures.voltage_figure(range(314), [v for _, v in sensor.readings()]).savefig('
        '"/dev/null", '
        'format="png")\n'
        'assert "matplotlib.pyplot" not in sys.modules, "pyplot was imported"\n'
    )
    result = subprocess.run(
        [sys.executable, '-c', code], capture_output=True, text=True, timeout=60, check=False
    )
    assert result.returncode == 0, result.stderr
