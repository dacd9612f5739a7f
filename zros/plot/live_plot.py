"""Live plots: numeric fields of topics as they arrive, in a scrolling time window.

Each topic gets one subscription; its callback runs on a thread that spins the node while the
plot runs, stamps the message with the node's clock (ROS time: sim time under
``use_sim_time``) and appends the values. The thread that draws (a window's event loop, or the
one writing files) only reads copies. The time axis is seconds since the plot started.
"""

from __future__ import annotations

import bisect
import math
import os
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from zros.bag.columns.addresses import Series, resolve, split_address
from zros.closing import Closing
from zros.plot.errors import PlotError
from zros.plot.figure import SeriesFigure, can_show
from zros.qos import QoS, Reliability

# matplotlib loads when a figure is made, the runtime (Zenoh) when a plot makes its own node
if TYPE_CHECKING:
    import numpy.typing as npt
    from matplotlib.figure import Figure

    from zros.cdr import Message
    from zros.node import Node
    from zros.pubsub import Subscriber

#: messages a plot's subscription keeps while the drawing thread is busy
DEPTH = 1000


@dataclass
class SeriesStats:
    """What a series received over the whole run (the window shows only the last part)."""

    count: int = 0
    minimum: float = math.inf
    maximum: float = -math.inf

    def add(self, value: float) -> None:
        """Count one value."""
        self.count += 1
        self.minimum = min(self.minimum, value)
        self.maximum = max(self.maximum, value)


class LivePlot(Closing):
    """A plot of numeric fields of live topics (a context manager).

    ``addresses`` are ``/topic/field/path`` strings (see :mod:`zros.bag.columns.addresses`);
    topics must appear on the network within ``wait`` seconds. ``window`` is the width of the
    time axis in seconds (None: everything since the start), ``filter`` the length of a moving
    average drawn over each line. :meth:`start` spins ``node`` on a thread of its own until
    :meth:`stop`; :meth:`update` puts the data received so far into the figure.
    """

    def __init__(
        self,
        node: Node,
        addresses: Sequence[str],
        *,
        window: float | None = 10.0,
        filter: int | None = None,
        wait: float = 5.0,
        show: bool = False,
    ) -> None:
        if window is not None and window <= 0:
            raise ValueError(f'the window is a number of seconds above 0, not {window}')
        if not addresses:
            raise PlotError('nothing to plot: give at least one /topic/field address')
        self.node = node
        self.window = window
        self.series = self._resolve(list(addresses), wait)
        topics = list(dict.fromkeys(s.topic for s in self.series))
        self.plot = SeriesFigure(
            self.series,
            filter=filter,
            title=', '.join(topics),
            xlabel='time since the start [s]',
            show=show,
        )
        self.stats = [SeriesStats() for _ in self.series]
        self.received = 0  #: messages received (all topics together)
        self._lock = threading.Lock()
        self._times: list[list[float]] = [[] for _ in self.series]
        self._values: list[list[float]] = [[] for _ in self.series]
        self._target: int | None = None
        self._reached = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.start_ns = node.now().nanoseconds
        self._subscriptions: list[Subscriber[Message]] = []
        try:
            for topic in topics:
                numbers = [n for n, s in enumerate(self.series) if s.topic == topic]
                self._subscriptions.append(self._subscribe(topic, numbers))
        except BaseException:
            self.close()
            raise

    # --- set-up ------------------------------------------------------------------------------

    def _resolve(self, addresses: list[str], wait: float) -> list[Series]:
        node = self.node
        graph = node.graph

        def topics() -> dict[str, list[str]]:
            return graph.topics(node.scheme.namespace)

        graph.wait_until(lambda: all(split_address(a, list(topics())) for a in addresses), wait)
        known = topics()
        series: list[Series] = []
        for address in addresses:
            if not split_address(address, list(known)):
                raise PlotError(
                    f'{address}: no topic on the network starts this address (waited {wait:g} s; '
                    'zros topic list shows the topics)'
                )
            found = resolve(
                address,
                {name: types[0] for name, types in known.items()},
                lambda topic, type_name: node.registry.get_class(type_name),
            )
            types = known[found[0].topic]
            if len(types) > 1:
                raise PlotError(f'{address}: topic {found[0].topic} has several types: {types}')
            series += found
        return series

    def _subscribe(self, topic: str, numbers: list[int]) -> Subscriber[Message]:
        node = self.node
        publishers = node.graph.publishers(node.scheme.key(node.resolve_name(topic)))
        reliable = all(p.qos is None or p.qos.reliable for p in publishers)
        qos = QoS(DEPTH, Reliability.RELIABLE if reliable else Reliability.BEST_EFFORT)
        chosen = [(n, self.series[n]) for n in numbers]

        def on_message(message: Message) -> None:
            stamp = (node.now().nanoseconds - self.start_ns) / 1e9
            values = []
            for _, item in chosen:
                try:
                    values.append(item.value(message))
                except (AttributeError, IndexError, TypeError, ValueError):
                    values.append(math.nan)
            with self._lock:
                for (number, _), value in zip(chosen, values, strict=True):
                    self._times[number].append(stamp)
                    self._values[number].append(value)
                    if not math.isnan(value):
                        self.stats[number].add(value)
                self.received += 1
                if self._target is not None and self.received >= self._target:
                    self._reached.set()

        return node.create_subscription(self.series[numbers[0]].type_name, topic, on_message, qos)

    # --- running -----------------------------------------------------------------------------

    @property
    def figure(self) -> Figure:
        """The matplotlib figure."""
        return self.plot.figure

    def elapsed(self) -> float:
        """Seconds since the plot started, on the node's clock."""
        return (self.node.now().nanoseconds - self.start_ns) / 1e9

    def start(self) -> None:
        """Spin the node on a thread of its own: messages arrive from now on."""
        if self._thread is not None:
            return
        self._stop.clear()

        def spin() -> None:
            while not self._stop.is_set() and self.node.ok():
                self.node.spin_once(timeout=0.05)

        self._thread = threading.Thread(target=spin, name='zros plot', daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop spinning (messages already received stay)."""
        thread, self._thread = self._thread, None
        if thread is None:
            return
        self._stop.set()
        thread.join(5)  # spin_once returns within its 50 ms timeout

    def wait_for_messages(self, count: int | None, timeout: float) -> bool:
        """Wait until ``count`` messages arrived in all (None: just wait), up to ``timeout`` s."""
        if count is None:
            self._stop.wait(timeout)
            return False
        with self._lock:
            if self.received >= count:
                return True
            self._target = count
            self._reached.clear()
        return self._reached.wait(timeout)

    def data(self, number: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The times and values series ``number`` holds now (the window's and a few before)."""
        with self._lock:
            return np.array(self._times[number]), np.array(self._values[number])

    def _trim(self, start: float) -> None:
        keep = max(self.plot.filter or 1, 1)  # the values the first visible average needs
        with self._lock:
            for times, values in zip(self._times, self._values, strict=True):
                cut = bisect.bisect_left(times, start) - keep
                if cut > 0:
                    del times[:cut]
                    del values[:cut]

    def update(self) -> None:
        """Put the data received so far into the figure and scroll the time axis."""
        end = self.elapsed()
        with self._lock:
            last = max((times[-1] for times in self._times if times), default=0.0)
        end = max(end, last)
        if self.window is None:
            start = 0.0
            end = max(end, 1.0)
        else:
            start = end - self.window
            if start < 0:
                start, end = 0.0, self.window
            self._trim(start)
        for number in range(len(self.series)):
            self.plot.set_data(number, *self.data(number))
        self.plot.fit(start, end)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the figure to a file (PNG, SVG... by the extension)."""
        self.plot.save(os.fspath(path))

    def close(self) -> None:
        """Stop spinning and withdraw the subscriptions."""
        self.stop()
        for subscription in self._subscriptions:
            subscription.close()
        self._subscriptions.clear()


def _figure_open(figure: Figure) -> bool:
    import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    return bool(plt.fignum_exists(figure.number))


def run(
    plot: LivePlot,
    *,
    duration: float | None = None,
    count: int | None = None,
    png: str | os.PathLike[str] | None = None,
    frames_dir: str | os.PathLike[str] | None = None,
    show: bool = False,
    interval: float | None = None,
    started: Callable[[], object] | None = None,
) -> int:
    """Run ``plot`` until ``duration`` seconds, ``count`` messages, Ctrl-C or a closed window.

    Redraws every ``interval`` seconds (default 0.1 in a window, 0.5 for frames), writing each
    frame as ``frame_00000.png``... into ``frames_dir``, and the last one into ``png``.
    ``started()`` is called once messages flow and Ctrl-C is handled. Returns the number of
    frames written.
    """
    period = interval if interval is not None else (0.1 if show else 0.5)
    if period <= 0:
        raise ValueError(f'the interval between frames is above 0 s, not {period}')
    frames = Path(frames_dir) if frames_dir is not None else None
    if frames is not None:
        frames.mkdir(parents=True, exist_ok=True)
    drawing = show or frames is not None
    written = 0
    deadline = None if duration is None else time.monotonic() + duration
    next_frame = time.monotonic()
    interrupted = False
    try:
        plot.start()
        if started is not None:
            started()
        while True:
            now = time.monotonic()
            if deadline is not None and now >= deadline:
                break
            if count is not None and plot.received >= count:
                break
            if show and not _figure_open(plot.figure):
                break
            if drawing and now >= next_frame:
                plot.update()
                if frames is not None:
                    plot.save(frames / f'frame_{written:05d}.png')
                    written += 1
                next_frame = max(next_frame + period, now)
            pause = 0.5
            if drawing:
                pause = min(pause, next_frame - time.monotonic())
            if deadline is not None:
                pause = min(pause, deadline - time.monotonic())
            pause = max(pause, 0.001)
            if show:
                import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

                plt.pause(pause)
            else:
                plot.wait_for_messages(count, pause)
    except KeyboardInterrupt:
        interrupted = True
    finally:
        plot.stop()
    plot.update()
    if frames is not None:
        plot.save(frames / f'frame_{written:05d}.png')
        written += 1
    if png is not None:
        plot.save(png)
    if show and not interrupted and _figure_open(plot.figure):
        import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

        plot.figure.canvas.draw_idle()
        plt.show()  # the data stopped; the window stays until it is closed
    return written


def live(
    addresses: Sequence[str],
    *,
    window: float | None = 10.0,
    filter: int | None = None,
    node: Node | None = None,
    duration: float | None = None,
    png: str | os.PathLike[str] | None = None,
    frames_dir: str | os.PathLike[str] | None = None,
    show: bool | None = None,
    count: int | None = None,
    interval: float | None = None,
    wait: float = 5.0,
) -> Figure:
    """Plot numeric fields of live topics, like rqt_plot; returns the figure.

    >>> zros.plot.live(['/imu/linear_acceleration/x'], filter=5, duration=10, png='imu.png')
    ... # doctest: +SKIP

    ``addresses`` are ``/topic/field/path`` strings: ``/odom/twist/twist/linear/x``, a message
    field for all its numbers (``/imu/angular_velocity``), ``/joint_states/position[0]`` for an
    element. One line per field, and with ``filter=N`` a moving average of N values over each
    (the rosR tutorial's filter). The time axis shows the last ``window`` seconds (None: all).

    It runs until ``duration`` seconds passed, ``count`` messages arrived (all topics
    together), Ctrl-C, or the window is closed. ``png`` receives the last picture,
    ``frames_dir`` one PNG per ``interval``. ``show`` opens a window (default: when neither file
    option is given and matplotlib has a display). ``node`` (default: a node of its own on the
    default connection) is spun on a thread of its own while the plot runs.
    """
    if show is None:
        show = png is None and frames_dir is None and can_show()
    own = node is None
    if node is None:
        from zros.node import Node  # noqa: PLC0415 (import zros.plot loads no Zenoh)

        node = Node(f'zros_plot_{os.getpid()}', enable_rosout=False, start_parameter_services=False)
    try:
        with LivePlot(node, addresses, window=window, filter=filter, wait=wait, show=show) as plot:
            run(
                plot,
                duration=duration,
                count=count,
                png=png,
                frames_dir=frames_dir,
                show=show,
                interval=interval,
            )
            return plot.figure
    finally:
        if own:
            node.destroy()
