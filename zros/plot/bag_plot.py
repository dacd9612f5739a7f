"""Plots from recordings: numeric fields of a bag's topics against the bag's time.

The values come from ``Bag.columns`` (straight from the CDR bytes, no message objects), the
times are the receive times the recording holds, in seconds from its first message.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.columns.addresses import Series, topic_series
from zros.plot.errors import PlotError
from zros.plot.figure import SeriesFigure

# matplotlib loads when a figure is made, zros.bag (type registry, rosbags) when a bag is read
if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from zros.bag import Bag


def bag_series(recording: Bag, addresses: Sequence[str]) -> list[Series]:
    """The series ``addresses`` name in a recording's topics."""
    topic_types = {name: info.type_name for name, info in recording.topics.items()}
    series: list[Series] = []
    for address in addresses:
        series += topic_series(
            address, topic_types, lambda name, _: recording.message_class(name), recording.path.name
        )
    return series


def bag_figure(
    path: str | os.PathLike[str],
    addresses: Sequence[str],
    *,
    filter: int | None = None,
    start: float | None = None,
    end: float | None = None,
    show: bool = False,
) -> SeriesFigure:
    """The :class:`SeriesFigure` of :func:`bag` (its lines hold the data)."""
    from zros.bag import Bag  # noqa: PLC0415 (import zros.plot stays light)

    if not addresses:
        raise PlotError('nothing to plot: give at least one /topic/field address')
    with Bag(os.fspath(path)) as recording:
        series = bag_series(recording, addresses)
        origin = recording.start_ns
        first = None if start is None else origin + round(start * 1e9)
        last = None if end is None else origin + round(end * 1e9)
        plot = SeriesFigure(
            series,
            filter=filter,
            title=f'{recording.path.name}: ' + ', '.join(dict.fromkeys(s.topic for s in series)),
            xlabel='time since the start of the recording [s]',
            show=show,
        )
        for topic in dict.fromkeys(s.topic for s in series):
            numbers = [n for n, s in enumerate(series) if s.topic == topic]
            fields = list(dict.fromkeys(series[n].field for n in numbers))
            columns = recording.columns(topic, fields, first, last)
            times = (columns['time'] - origin) / 1e9
            for number in numbers:
                plot.set_data(number, times, series[number].column(columns))
        duration = recording.duration_ns / 1e9
    plot.fit(start if start is not None else 0.0, end if end is not None else duration)
    return plot


def bag(
    path: str | os.PathLike[str],
    addresses: Sequence[str],
    png: str | os.PathLike[str] | None = None,
    filter: int | None = None,
    *,
    start: float | None = None,
    end: float | None = None,
    show: bool = False,
) -> Figure:
    """Plot numeric fields of a recording's topics; returns the figure.

    >>> zros.plot.bag('run1', ['/odom/twist/twist/linear/x'], png='speed.png')  # doctest: +SKIP

    ``path`` is anything ``zros.bag.Bag`` opens (a bag folder, ``.mcap``, ``.db3``, ROS 1
    ``.bag``); ``addresses`` are ``/topic/field/path`` strings as for :func:`live`. The x axis
    is the receive time in seconds from the recording's first message; ``start`` and ``end``
    (in those seconds) keep a part. ``filter=N`` adds a moving average of N values over each
    line. ``png`` (or ``.svg``, ``.pdf``) receives the picture; ``show`` opens a window.
    """
    plot = bag_figure(path, addresses, filter=filter, start=start, end=end, show=show)
    if png is not None:
        plot.save(os.fspath(png))
    if show:
        import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

        plt.show()
    return plot.figure


def is_recording(path: str) -> bool:
    """Whether a command-line argument names a file or folder (a bag), not a topic address."""
    return Path(path).exists()
