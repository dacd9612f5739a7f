"""The tutorial's three figures, built with matplotlib (imported only when a figure is made).

Without ``gui`` a figure is a plain ``matplotlib.figure.Figure`` on the Agg canvas: no pyplot,
no display, no backend chosen for the rest of the process. With ``gui`` it is a pyplot figure in
a window. Each ``*_figure`` function returns the figure, so that tests and notebooks can look at
its axes, lines and labels without reading a PNG back.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from zros.demo.analysis import WINDOW, Calibration, moving_average
from zros.demo.sensor import DISTANCE_TOPIC, MAX_RANGE, MIN_RANGE, PAPER_FIT, VOLTAGE_TOPIC

if TYPE_CHECKING:
    import numpy.typing as npt
    from matplotlib.figure import Figure

DPI = 100


def new_figure(
    gui: bool = False, *, figsize: tuple[float, float] = (8, 4), rows: int = 1
) -> Figure:
    """An empty figure with ``rows`` axes stacked: on the Agg canvas, or in a window (``gui``)."""
    if gui:
        import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

        figure = plt.figure(figsize=figsize)
    else:
        from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: PLC0415 (lazy: matplotlib, only for a figure)
        from matplotlib.figure import Figure  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

        figure = Figure(figsize=figsize)
        FigureCanvasAgg(figure)
    if rows == 1:
        figure.add_subplot()
    else:
        figure.subplots(rows, 1, sharex=True, height_ratios=[3] + [1] * (rows - 1))
    return figure


def voltage_figure(
    times: Sequence[float] | npt.NDArray[np.float64] = (),
    volts: Sequence[float] | npt.NDArray[np.float64] = (),
    *,
    window: int = WINDOW,
    gui: bool = False,
) -> Figure:
    """The voltage readings (dots) and their moving average (a line) over time: ``times`` in
    seconds from the first reading (the recording's clock), one per reading."""
    figure = new_figure(gui)
    axes = figure.axes[0]
    axes.plot([], [], '.', color='0.6', markersize=3, label='measured')
    axes.plot([], [], '-', color='C3', label=f'moving average of {window}')
    axes.set(xlabel='time [s]', ylabel='voltage [V]', title=VOLTAGE_TOPIC)
    axes.legend(loc='upper left')
    axes.grid(alpha=0.3)
    update_voltage_figure(figure, times, volts, window=window)
    return figure


def update_voltage_figure(
    figure: Figure,
    times: Sequence[float] | npt.NDArray[np.float64],
    volts: Sequence[float] | npt.NDArray[np.float64],
    *,
    window: int = WINDOW,
) -> None:
    """Show ``volts`` (all readings so far) at ``times`` in a figure from :func:`voltage_figure`
    (the shorter of the two sets how many are shown)."""
    axes = figure.axes[0]
    raw, filtered = axes.lines[:2]
    count = min(len(times), len(volts))
    data = np.asarray(volts[:count], dtype=float)
    seconds = np.asarray(times[:count], dtype=float)
    raw.set_data(seconds, data)
    filtered.set_data(seconds, moving_average(data, window))
    axes.relim()
    axes.autoscale_view()


def fit_figure(calibration: Calibration, *, gui: bool = False) -> Figure:
    """The calibration pairs, the fitted curve, the paper's two points; residuals below."""
    figure = new_figure(gui, figsize=(7, 5.5), rows=2)
    top, bottom = figure.axes
    top.plot(
        calibration.volt, calibration.dist, '.', color='0.5', markersize=4,
        label=f'{len(calibration.volt)} calibration pairs (from the bag)',
    )  # fmt: skip
    volts = np.linspace(calibration.volt.min(), calibration.volt.max(), 400)
    degree = calibration.curve.degree()
    top.plot(volts, calibration.curve(volts), '-', color='C0', label=f'dist ~ poly(volt, {degree})')
    top.plot(
        list(PAPER_FIT), list(PAPER_FIT.values()), 'x', color='C3', markersize=9, mew=2,
        label='the rosR paper: 0.164 m at 0.8 V, 0.061 m at 2.0 V',
    )  # fmt: skip
    top.set(ylabel='distance [m]', title='GP2D120 characteristic, fitted')
    top.legend(loc='upper right')
    top.grid(alpha=0.3)
    bottom.plot(calibration.volt, 1000 * calibration.residuals, '.', color='C0', markersize=3)
    bottom.axhline(0.0, color='0.3', linewidth=0.8)
    bottom.set(
        xlabel='voltage [V]',
        ylabel='residual [mm]',
        title=f'residual error {1000 * calibration.rms_error:.2f} mm RMS',
    )
    bottom.grid(alpha=0.3)
    figure.tight_layout()
    return figure


def distance_figure(
    times: Sequence[float] | npt.NDArray[np.float64],
    distances: Sequence[float] | npt.NDArray[np.float64],
    truth: Sequence[float] | npt.NDArray[np.float64] | None = None,
    *,
    window: int = WINDOW,
    gui: bool = False,
) -> Figure:
    """The ranges received on ``/sharpGP2D120/Distance`` over time (``times`` in seconds, one
    per range), the sensor's range limits, and (if given) where the simulated object really
    was at those times. A caption says why the ranges trail the object: each one comes from the
    moving average of the last ``window`` readings."""
    figure = new_figure(gui, figsize=(8, 4.4))
    axes = figure.axes[0]
    count = min(len(times), len(distances))
    seconds = np.asarray(times[:count], dtype=float)
    values = np.asarray(distances[:count], dtype=float)
    if truth is not None:
        real = np.asarray(truth, dtype=float)[:count]
        axes.plot(seconds[: len(real)], real, '-', color='0.7', linewidth=3,
                  label='the simulated object')  # fmt: skip
    axes.plot(seconds, values, '-', color='C2', label='sensor_msgs/Range received')
    axes.axhline(MIN_RANGE, color='C3', linestyle='--', linewidth=1, label='min_range, max_range')
    axes.axhline(MAX_RANGE, color='C3', linestyle='--', linewidth=1)
    axes.set(xlabel='time [s]', ylabel='range [m]', title=DISTANCE_TOPIC, ylim=(0.0, 0.37))
    axes.legend(loc='upper center', ncols=3, fontsize='small')
    axes.grid(alpha=0.3)
    period = float(np.median(np.diff(seconds))) if count > 1 else 0.0
    figure.text(
        0.5, 0.01,
        f'Each range comes from the moving average of the last {window} voltages, so it trails '
        f'the object by about {(window - 1) / 2:g} readings ({(window - 1) / 2 * period:.2f} s).',
        ha='center', va='bottom', fontsize='small', color='0.3',
    )  # fmt: skip
    figure.subplots_adjust(bottom=0.2)
    return figure


def save(figure: Figure, path: str | os.PathLike[str]) -> str:
    """Write ``figure`` as a PNG at ``path``; returns the path."""
    figure.savefig(os.fspath(path), dpi=DPI)
    return os.fspath(path)


class LiveVoltagePlot:
    """The voltage figure, redrawn as readings arrive (rosR's demo1).

    In a window (``gui``) it is redrawn every ``interval`` seconds; without, the PNG at ``path``
    is rewritten as often (an image viewer that reloads it shows it live), and once more by
    :meth:`finish`.
    """

    def __init__(
        self, path: str | os.PathLike[str], *, gui: bool = False, interval: float = 0.5
    ) -> None:
        self.path = os.fspath(path)
        self.gui = gui
        self.interval = interval
        self.figure = voltage_figure(gui=gui)
        self._shown = 0
        self._next = 0.0
        if gui:
            import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

            plt.ion()
            plt.show(block=False)

    def update(self, times: Sequence[float], volts: Sequence[float], force: bool = False) -> None:
        """Show ``volts`` at ``times`` (seconds) if there are new ones and it is time to redraw
        (or ``force``)."""
        now = time.monotonic()
        count = min(len(times), len(volts))
        if count == self._shown or not (force or now >= self._next):
            return
        update_voltage_figure(self.figure, times, volts)
        self._shown = count
        self._next = now + self.interval
        if self.gui:
            import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

            plt.pause(0.001)
        else:
            save(self.figure, self.path)

    def finish(self, times: Sequence[float], volts: Sequence[float]) -> str:
        """Draw every reading and write the PNG; returns its path."""
        update_voltage_figure(self.figure, times, volts)
        self._shown = min(len(times), len(volts))
        return save(self.figure, self.path)


#: matplotlib backends that draw files only
_FILE_BACKENDS = {'agg', 'cairo', 'pdf', 'pgf', 'ps', 'svg', 'template'}


def gui_backend() -> str | None:
    """The matplotlib backend that would draw windows here, or None (no display, say)."""
    import matplotlib  # noqa: PLC0415 (lazy: matplotlib, only for a figure)
    import matplotlib.pyplot  # resolves the backend  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    backend = str(matplotlib.get_backend())
    return None if backend.lower() in _FILE_BACKENDS else backend


def show() -> None:
    """Keep the figures' windows open until the user closes them (``--gui``)."""
    import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    plt.ioff()
    plt.show()
