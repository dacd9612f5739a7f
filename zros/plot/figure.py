"""The figure both time plots draw into: a line per series, its moving average, the axes.

matplotlib is imported here, when a figure is made: ``zros.plot`` itself stays light. Without a
window the figure is a bare ``matplotlib.figure.Figure`` (Agg renders it into files; pyplot and
its global state are never involved), with one it comes from pyplot.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from zros.bag.columns.addresses import Series
from zros.plot.smoothing import moving_average

if TYPE_CHECKING:
    import numpy.typing as npt
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

#: backends that draw into files only
FILE_BACKENDS = frozenset({'agg', 'cairo', 'pdf', 'pgf', 'ps', 'svg', 'template'})


def can_show() -> bool:
    """Whether matplotlib can open a window here (an interactive backend, a display)."""
    import matplotlib  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    backend = str(matplotlib.get_backend()).lower()
    return backend not in FILE_BACKENDS and 'inline' not in backend


def new_figure(show: bool, size: tuple[float, float]) -> Figure:
    """A figure for a window (through pyplot) or for files only (no pyplot)."""
    if show:
        import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

        return plt.figure(figsize=size, layout='constrained')
    from matplotlib.figure import Figure  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    return Figure(figsize=size, layout='constrained')


def _limits(arrays: Sequence[npt.NDArray[np.float64]]) -> tuple[float, float] | None:
    finite = [a[np.isfinite(a)] for a in arrays]
    finite = [a for a in finite if a.size]
    if not finite:
        return None
    low = min(float(a.min()) for a in finite)
    high = max(float(a.max()) for a in finite)
    margin = (high - low) * 0.05 if high > low else max(abs(high) * 0.1, 0.5)
    return low - margin, high + margin


class SeriesFigure:
    """A time plot of numeric series: one line each, plus a moving average when filtering.

    ``lines[i]`` is the line of ``series[i]``; ``filtered[i]`` its moving average of ``filter``
    values (only when ``filter`` is given). Times are seconds on the x axis.
    """

    def __init__(
        self,
        series: Sequence[Series],
        *,
        filter: int | None = None,
        title: str = '',
        xlabel: str = 'time [s]',
        show: bool = False,
        size: tuple[float, float] = (8.0, 4.5),
    ) -> None:
        if filter is not None and filter < 1:
            raise ValueError(f'the filter length is a number of values, 1 or more, not {filter}')
        self.series = list(series)
        self.filter = filter
        self.figure: Figure = new_figure(show, size)
        self.axes: Axes = self.figure.add_subplot()
        self.lines: list[Line2D] = []
        self.filtered: list[Line2D] = []
        for number, item in enumerate(self.series):
            color = f'C{number % 10}'
            if filter is None:
                (line,) = self.axes.plot([], [], '-', color=color, linewidth=1.2, label=item.label)
            else:
                (line,) = self.axes.plot(
                    [], [], '-', color=color, linewidth=0.8, alpha=0.45, label=item.label
                )
                (smooth,) = self.axes.plot(
                    [], [], '-', color=color, linewidth=2.0,
                    label=f'{item.label}, moving average of {filter}',
                )  # fmt: skip
                self.filtered.append(smooth)
            self.lines.append(line)
        ylabel = self.series[0].label if len(self.series) == 1 else 'value'
        self.axes.set(xlabel=xlabel, ylabel=ylabel, title=title)
        self.axes.grid(True, color='0.9')
        # placed at each draw where it covers the fewest points: a fixed corner hid the
        # line of a counter that started high (a topic's stamp, a sequence number)
        self.axes.legend(loc='best', fontsize='small')

    def set_data(
        self, number: int, times: npt.NDArray[np.float64], values: npt.NDArray[np.float64]
    ) -> None:
        """The points of series ``number`` (its moving average follows)."""
        self.lines[number].set_data(times, values)
        if self.filter is not None:
            self.filtered[number].set_data(times, moving_average(values, self.filter))

    def fit(self, start: float | None = None, end: float | None = None) -> None:
        """x limits ``start..end`` (default: the data's), y limits around the data in them."""
        arrays_x = [np.asarray(line.get_xdata(), np.float64) for line in self.lines]
        present = [x for x in arrays_x if x.size]
        if start is None:
            start = min((float(x.min()) for x in present), default=0.0)
        if end is None:
            end = max((float(x.max()) for x in present), default=1.0)
        if end <= start:
            end = start + 1.0
        self.axes.set_xlim(start, end)
        visible = []
        for line in [*self.lines, *self.filtered]:
            x = np.asarray(line.get_xdata(), np.float64)
            y = np.asarray(line.get_ydata(), np.float64)
            visible.append(y[(x >= start) & (x <= end)])
        limits = _limits(visible)
        if limits is not None:
            self.axes.set_ylim(*limits)

    def save(self, path: str, dpi: float = 100) -> None:
        """Write the figure to a file (PNG, SVG, PDF... by the name's extension)."""
        self.figure.savefig(path, dpi=dpi)
