"""``zros demo`` from end to end: the bag, a router, the player, the tutorial's node, the report.

Three Zenoh sessions stand for three processes of a ROS system, all connected over loopback to a
router inside this process: ``ros2 bag play`` (a :class:`zros.bag.Player` on node
``rosbag2_player``), the tutorial's node ``R_demo`` (:class:`zros.demo.analysis.RangeNode`),
and ``ros2 topic echo`` (node ``zros_demo_echo``, counting what reaches the graph).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import zros
from zros.bag import Player
from zros.demo.analysis import RangeNode, read_calibration
from zros.demo.figures import (
    LiveVoltagePlot,
    distance_figure,
    fit_figure,
    gui_backend,
    save,
    show,
)
from zros.demo.sensor import (
    CALIBRATION_TOPIC,
    DISTANCE_TOPIC,
    LINEARIZATION,
    PAIRS,
    PAPER_FIT,
    READINGS,
    VOLTAGE_TOPIC,
    register_linearization,
    sweep,
)
from zros.demo.tutorial_bag import ensure_bag
from zros.transport import Transport, TransportConfig, start_router
from zros.wire import session_config

if TYPE_CHECKING:
    from zros.bag.read.source import RawMessage

DEFAULT_OUTPUT = 'zros-demo'
DEFAULT_RATE = 10.0
TOLERANCE = 0.10  #: the acceptance: within 10 % of the paper's fitted distances
PNG_NAMES = {
    'voltage': 'voltage.png',
    'fit': 'fit.png',
    'distance': 'distance.png',
}
#: how long to wait for messages still in flight once the player is done
SETTLE = 5.0


@dataclass
class DemoResult:
    """What a run of the demo saw, made and wrote."""

    bag: Path
    bag_generated: bool
    voltages_played: int = 0
    pairs_played: int = 0
    voltages_received: int = 0
    pairs_received: int = 0  #: calibration pairs the echo node saw on the graph
    pairs_read: int = 0  #: calibration pairs read out of the bag and fitted
    ranges_published: int = 0
    ranges_received: int = 0
    fitted: dict[float, float] = field(default_factory=dict)  #: volts -> metres
    rms_error: float = 0.0  #: of the fit over the pairs, metres
    tracking_error: float = 0.0  #: ranges against the simulated object, RMS metres
    range_span: tuple[float, float] = (0.0, 0.0)
    pngs: dict[str, Path] = field(default_factory=dict)
    seconds: float = 0.0
    interrupted: bool = False  #: Ctrl-C ended it early

    @property
    def fit_ok(self) -> bool:
        """Whether the fit is within 10 % of the paper at 0.8 V and 2.0 V."""
        return all(
            abs(self.fitted.get(volt, 0.0) - paper) <= TOLERANCE * paper
            for volt, paper in PAPER_FIT.items()
        )

    @property
    def counts_ok(self) -> bool:
        """Whether every message made it: each voltage in the bag became a range received."""
        return (
            self.voltages_played == self.voltages_received == READINGS
            and self.ranges_published == self.ranges_received == READINGS
            and self.pairs_read == self.pairs_played == self.pairs_received == PAIRS
        )

    @property
    def ok(self) -> bool:
        """Whether the demo did all it should."""
        pngs = all(p.is_file() for p in self.pngs.values())
        return self.fit_ok and self.counts_ok and pngs and not self.interrupted


def _show(path: Path) -> str:
    """``path`` relative to the working directory when it is below it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def report(result: DemoResult) -> str:
    """The demo's closing report, as printed."""
    lines = [
        '',
        'zros demo report',
        f'  messages  {result.voltages_played} voltages played, {result.voltages_received} '
        f'received by R_demo',
        f'            {result.pairs_read} calibration pairs read from the bag '
        f'({result.pairs_received} of {result.pairs_played} played also seen on the graph)',
        f'            {result.ranges_published} sensor_msgs/Range published on {DISTANCE_TOPIC}, '
        f'{result.ranges_received} received',
    ]
    label = '  fit       dist ~ poly(volt, 8):'
    for volt, paper in PAPER_FIT.items():
        fitted = result.fitted.get(volt, float('nan'))
        off = 100 * (fitted - paper) / paper
        lines.append(
            f'{label} {volt:.1f} V -> {fitted:.3f} m (the paper: {paper:.3f} m, {off:+.1f} %)'
        )
        label = ' ' * len(label)
    lines.append(f'            residual error {1000 * result.rms_error:.2f} mm RMS')
    low, high = result.range_span
    if result.ranges_received:
        lines.append(
            f'  ranges    {low:.3f} m to {high:.3f} m; {1000 * result.tracking_error:.1f} mm RMS '
            'from the simulated object'
        )
    label = '  plots    '
    for name, path in result.pngs.items():
        lines.append(f'{label} {_show(path)}  ({_PLOT_TITLES[name]})')
        label = ' ' * len(label)
    lines.append(f'  done in {result.seconds:.1f} s')
    if result.interrupted:
        lines.append('  interrupted before the end of the bag')
    elif not result.counts_ok:
        lines.append('  NOT OK: messages were lost on the way')
    if not result.fit_ok:
        lines.append(f'  NOT OK: the fit is more than {TOLERANCE:.0%} off the paper')
    return '\n'.join(lines)


_PLOT_TITLES = {
    'voltage': 'voltage and its moving average',
    'fit': 'calibration pairs, fitted curve, residuals',
    'distance': 'ranges received',
}


def run_demo(
    output: str | os.PathLike[str] = DEFAULT_OUTPUT,
    *,
    rate: float = DEFAULT_RATE,
    gui: bool = False,
    regenerate: bool = False,
    log_every: int = 50,
    out: Callable[[str], object] = print,
) -> DemoResult:
    """Run the tutorial: make or reuse the bag in ``output``, play it at ``rate`` times its
    speed, analyse it, write the PNGs into ``output`` and print the report through ``out``."""
    started = time.monotonic()
    folder = Path(output)
    out('zros demo: the rosR tutorial on a simulated Sharp GP2D120 infrared distance sensor')
    if gui and gui_backend() is None:
        out('  --gui    no display here (matplotlib draws files only): writing the PNGs alone')
        gui = False
    bag, generated = ensure_bag(folder, regenerate=regenerate)
    result = DemoResult(bag, generated)
    made = 'made now' if generated else 'made before, reused'
    out(f'  bag      {_show(bag)} ({made}): {PAIRS} calibration pairs, {READINGS} voltages')
    calibration = read_calibration(bag)  # demo2: from the bag, as rosR's ros.BagRead
    result.pairs_read = len(calibration.volt)
    result.fitted = {volt: float(calibration.curve(volt)) for volt in PAPER_FIT}
    result.rms_error = calibration.rms_error
    register_linearization()

    with start_router() as router:
        out(f'  router   in this process, at {router.endpoint} (no network beyond loopback)')

        def config() -> TransportConfig:
            return session_config(router.endpoint, shared_memory=False)

        echo_session = Transport(config())
        player_session = Transport(config())
        echo = zros.Node('zros_demo_echo', transport=echo_session)
        player_node = zros.Node('rosbag2_player', transport=player_session)
        zros.init('R_demo', config=config())
        live = LiveVoltagePlot(folder / PNG_NAMES['voltage'], gui=gui)
        try:
            node = RangeNode(zros.default_node(), calibration, log_every)
            ranges = echo.create_subscription(
                'sensor_msgs/msg/Range', DISTANCE_TOPIC, qos='keep_all'
            )
            pairs = echo.create_subscription(LINEARIZATION, CALIBRATION_TOPIC, qos='keep_all')
            node.publisher.wait_for_subscribers(5)
            played = {VOLTAGE_TOPIC: 0, CALIBRATION_TOPIC: 0}
            stamps: list[int] = []  #: recorded times of the voltages played, in order

            def count(message: RawMessage) -> None:
                played[message.connection.topic] += 1
                if message.connection.topic == VOLTAGE_TOPIC:
                    stamps.append(message.timestamp)

            player = Player(player_node, bag, rate=rate, wait_for_subscribers=5, on_message=count)
            out(f'  playing  at {rate:g}x the recorded speed ({_seconds(player)} s of data)')
            received: list[float] = []
            seen_pairs = 0
            player.start()
            settle: float | None = None
            while zros.ok():
                zros.spin_once(timeout=0.02)
                node.handle()
                received.extend(message.range for message in ranges.take())
                seen_pairs += len(pairs.take())
                live.update(_seconds_of(stamps), node.readings)
                if player.done:
                    settle = settle or time.monotonic() + SETTLE
                    complete = (
                        len(node.readings) >= played[VOLTAGE_TOPIC]
                        and len(received) >= len(node.distances)
                        and seen_pairs >= played[CALIBRATION_TOPIC]
                    )
                    if complete or time.monotonic() > settle:
                        break
            result.interrupted = not zros.ok()
            player.close()
        finally:
            zros.shutdown()
            for other in (echo, player_node):
                other.destroy()
            for session in (echo_session, player_session):
                session.close()

    result.voltages_played = played[VOLTAGE_TOPIC]
    result.pairs_played = played[CALIBRATION_TOPIC]
    result.voltages_received = len(node.readings)
    result.pairs_received = seen_pairs
    result.ranges_published = len(node.distances)
    result.ranges_received = len(received)
    if received:
        result.range_span = (min(received), max(received))
        truth = sweep(len(received))
        errors = [(r - t) ** 2 for r, t in zip(received, truth, strict=True)]
        result.tracking_error = (sum(errors) / len(errors)) ** 0.5
    # a reliable keep-all stream: the n-th reading received is the n-th voltage played
    seconds = _seconds_of(stamps)
    result.pngs['voltage'] = Path(live.finish(seconds, node.readings))
    figures = [live.figure, fit_figure(calibration, gui=gui)]
    result.pngs['fit'] = Path(save(figures[-1], folder / PNG_NAMES['fit']))
    figures.append(distance_figure(seconds, received, sweep(READINGS), gui=gui))
    result.pngs['distance'] = Path(save(figures[-1], folder / PNG_NAMES['distance']))
    result.seconds = time.monotonic() - started
    out(report(result))
    if gui:
        out('close the windows to end')
        show()
    return result


def _seconds_of(stamps: list[int]) -> list[float]:
    """Recorded times in nanoseconds as seconds from the first."""
    return [(stamp - stamps[0]) / 1e9 for stamp in stamps] if stamps else []


def _seconds(player: Player) -> str:
    return f'{(player.end_ns - player.start_ns) / 1e9:.1f}'
