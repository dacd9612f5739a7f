"""ROS time, durations, and nodes that follow /clock."""

from __future__ import annotations

import datetime
import logging
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np
import pytest

import zros
from zros.node import Node
from zros.runtime.clock import Duration, Time
from zros.testing import wait_for
from zros.transport import Transport


def test_time_and_duration_arithmetic() -> None:
    stamp = Time(1740933158_226629828)  # floats cannot hold nanoseconds of 2025
    assert (stamp.sec, stamp.nanosec) == (1740933158, 226629828)
    assert str(stamp) == '1740933158.226629828'
    assert Time.from_msg(stamp.to_msg()) == stamp
    later = stamp + Duration.from_seconds(1.5)
    assert later - stamp == Duration(1_500_000_000)
    assert later - Duration.from_seconds(1.5) == stamp
    assert float(later - stamp) == 1.5
    assert (Duration.from_seconds(2) * 1.5).seconds == 3.0
    assert (Duration.from_seconds(3) / 2).seconds == 1.5
    assert -Duration(5) == Duration(-5) and Duration(5) > Duration(-5)
    assert Duration.from_msg(Duration.from_seconds(2.25).to_msg()).seconds == 2.25
    assert stamp.to_datetime() == datetime.datetime(
        2025, 3, 2, 16, 32, 38, 226629, tzinfo=datetime.timezone.utc
    )
    assert stamp < later and sorted([later, stamp]) == [stamp, later]
    with pytest.raises(TypeError):
        stamp + stamp  # type: ignore[operator]


def test_time_and_duration_take_rclpys_keywords() -> None:
    assert Duration(seconds=1.5) == Duration(1_500_000_000) == Duration.from_seconds(1.5)
    assert Duration(seconds=1, nanoseconds=5) == Duration(1_000_000_005)
    assert Time(seconds=2, nanoseconds=7).nanoseconds == 2_000_000_007
    assert Time(nanoseconds=3) == Time(3)
    assert Duration(np.int64(4)) == Duration(4)  # numpy integers are integers
    assert Time(seconds=1.5) + Duration(seconds=0.5) == Time(seconds=2)


@pytest.mark.parametrize('kind', [Time, Duration])
@pytest.mark.parametrize('value', [0.5, 1.0, np.float64(2.5), '5'])
def test_time_and_duration_refuse_float_nanoseconds_at_once(
    kind: type[Time | Duration], value: object
) -> None:
    # rclpy's habit Duration(0.5) was 0 ns, silently; Time + it failed later with a format error
    name = kind.__name__
    with pytest.raises(TypeError, match=rf'{name}\(\) takes integer nanoseconds.*seconds='):
        kind(value)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match='integer nanoseconds'):
        kind(nanoseconds=value)  # type: ignore[arg-type]


def test_time_now_follows_the_wall_clock(zros_node: Callable[..., Node]) -> None:
    node = zros_node('clockwork')
    assert not node.use_sim_time
    assert abs(node.now().seconds - time.time()) < 1
    assert abs(zros.time_now().seconds - time.time()) < 1  # before zros.init too


@contextmanager
def clock_publisher(node: Node, speed: float) -> Iterator[dict[str, object]]:
    """Publish /clock every 5 ms of wall time, advancing ``speed`` x 5 ms; pausable."""
    pub = node.create_publisher('rosgraph_msgs/msg/Clock', '/clock')
    state: dict[str, object] = {'sim': 1000.0, 'paused': False, 'stop': False, 'jump': None}
    rate = zros.Rate(200)

    def run() -> None:
        message = zros.Message('rosgraph_msgs/msg/Clock')
        while not state['stop']:
            if state['jump'] is not None:
                state['sim'], state['jump'] = state['jump'], None
            if not state['paused']:
                state['sim'] = float(state['sim']) + 0.005 * speed  # type: ignore[arg-type]
                message.clock = Time.from_seconds(float(state['sim'])).to_msg()  # type: ignore[arg-type]
                pub.write(message)
            rate.sleep()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        yield state
    finally:
        state['stop'] = True
        thread.join(5)


def test_a_sim_time_timer_follows_clock_speed_and_pauses(zros_node: Callable[..., Node]) -> None:
    sim_node = zros_node('sim', use_sim_time=True)
    assert sim_node.use_sim_time and sim_node.now() == Time(0)
    ticks: list[float] = []
    sim_node.create_timer(0.1, lambda: ticks.append(time.monotonic()))
    with clock_publisher(zros_node('player'), speed=2.0) as state:
        assert wait_for(lambda: sim_node.now().seconds > 1000)
        sim_node.spin(timeout=0.2)  # settle
        ticks.clear()
        started = time.monotonic()
        sim_node.spin(timeout=1.5)
        rate = len(ticks) / (time.monotonic() - started)
        assert 16 <= rate <= 24, f'{rate:.1f} Hz'  # 10 Hz of sim time at 2x = 20 Hz of wall time
        state['paused'] = True
        sim_node.spin(timeout=0.1)  # the last /clock messages in flight
        count = len(ticks)
        paused_at = sim_node.now()
        sim_node.spin(timeout=0.5)
        assert len(ticks) == count and sim_node.now() == paused_at
        state['jump'] = 500.0  # a bag player looping back
        state['paused'] = False
        assert wait_for(lambda: sim_node.now().seconds < 600)
        sim_node.spin(timeout=0.5)
        assert 6 <= len(ticks) - count <= 14  # restarted at the same pace, no burst


def test_use_sim_time_switches_the_clock_at_run_time(zros_node: Callable[..., Node]) -> None:
    node = zros_node('switching')
    ticks: list[Time] = []
    node.create_timer(0.05, lambda: ticks.append(node.now()))
    with clock_publisher(zros_node('player'), speed=1.0):
        node.spin(timeout=0.3)
        assert abs(node.now().seconds - time.time()) < 5 and ticks  # wall time, ticking
        node.set_parameter('use_sim_time', True)
        assert node.use_sim_time
        assert wait_for(lambda: 1000 <= node.now().seconds < 1_000_000)  # /clock's time
        ticks.clear()
        node.spin(timeout=0.5)
        assert ticks and all(stamp.seconds < 1_000_000 for stamp in ticks)
        node.set_parameter('use_sim_time', False)
        assert abs(node.now().seconds - time.time()) < 5
        ticks.clear()
        node.spin(timeout=0.3)
        assert ticks and all(abs(stamp.seconds - time.time()) < 5 for stamp in ticks)
        received = node.clock.received  # left /clock: no more /clock messages reach the node
        node.spin(timeout=0.2)
        assert node.clock.received == received


def test_a_clock_switch_restarts_timers_without_a_burst(zros_node: Callable[..., Node]) -> None:
    node = zros_node('restarting')
    ticks: list[Time] = []
    node.create_timer(1.0, lambda: ticks.append(node.now()))
    node.clock.set(Time.from_seconds(2e9))  # sim time past the monotonic clock, as a bag's
    node.set_parameter('use_sim_time', True)
    node.spin(timeout=0.3)
    assert ticks == []  # no early tick: the period restarts on sim time
    node.clock.set(Time.from_seconds(1.0))  # sim time behind the monotonic clock
    node.spin(timeout=0.1)
    node.set_parameter('use_sim_time', False)
    node.spin(timeout=0.3)
    assert ticks == []  # nor back on wall time


def test_use_sim_time_from_arguments_and_environment(
    zros_node: Callable[..., Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    assert zros_node('a', args=['--ros-args', '-p', 'use_sim_time:=true']).use_sim_time
    assert not zros_node('b', args=['--ros-args', '-p', 'use_sim_time:=false']).use_sim_time
    monkeypatch.setenv('ZROS_USE_SIM_TIME', '1')
    assert zros_node('c').use_sim_time
    assert not zros_node('d', use_sim_time=False).use_sim_time


def test_a_sim_time_rate_waits_for_the_clock(zros_node: Callable[..., Node]) -> None:
    sim_node = zros_node('looper', use_sim_time=True)
    with clock_publisher(zros_node('player'), speed=4.0):
        assert wait_for(lambda: sim_node.now().seconds > 1000)
        rate = sim_node.create_rate(10)  # 10 Hz of sim time: 40 Hz of wall time here
        start_sim, start_wall = sim_node.now(), time.monotonic()
        for _ in range(8):
            rate.sleep()
        sim_elapsed = (sim_node.now() - start_sim).seconds
        wall_elapsed = time.monotonic() - start_wall
        assert 0.7 <= sim_elapsed <= 1.0
        assert wall_elapsed < sim_elapsed  # sim time runs faster than the wall


def test_a_timer_made_before_the_clock_starts_counts_from_its_first_message(
    zros_node: Callable[..., Node],
) -> None:
    sim_node = zros_node('viewer', use_sim_time=True)
    ticks: list[Time] = []
    sim_node.create_timer(1.0, lambda: ticks.append(sim_node.now()))
    clock = zros_node('player').create_publisher('rosgraph_msgs/msg/Clock', '/clock')
    assert clock.wait_for_subscribers()

    def move_to(seconds: float) -> None:
        stamp = Time.from_seconds(seconds)
        clock.write(zros.Message('rosgraph_msgs/msg/Clock', clock=stamp.to_msg()))
        assert wait_for(lambda: sim_node.now() == stamp)
        sim_node.spin_once(timeout=0)

    move_to(1000.0)  # sim time starts: no burst for the 1000 s the timer "missed"
    move_to(1000.5)
    assert ticks == []
    move_to(1001.0)
    assert ticks == [Time.from_seconds(1001.0)]


@pytest.mark.parametrize('wire', ['bridge', 'rmw_zenoh'])
def test_the_sim_clock_takes_the_samples_its_wire_admits(
    zros_node: Callable[..., Node],
    zros_transport: Callable[..., Transport],
    caplog: pytest.LogCaptureFixture,
    wire: str,
) -> None:
    """A /clock sample without an rmw_zenoh attachment moves the clock through a bridge (no
    attachments there), and under rmw_zenoh is dropped as a subscriber drops it."""
    sim = zros_node('sim', wire=wire, use_sim_time=True, start_parameter_services=False)
    player = zros_node('player', wire=wire, start_parameter_services=False)
    clock = player.create_publisher('rosgraph_msgs/msg/Clock', '/clock')
    assert clock.wait_for_subscribers()
    raw = zros_transport().session.declare_publisher(clock.key)
    assert wait_for(lambda: raw.matching_status.matching)
    message = zros.Message('rosgraph_msgs/msg/Clock', clock=Time.from_seconds(5).to_msg())
    with caplog.at_level(logging.DEBUG, logger='zros'):
        raw.put(zros.cdr.encode(message))  # no attachment
        if wire == 'bridge':
            assert wait_for(lambda: sim.now() == Time.from_seconds(5))
        else:
            assert wait_for(lambda: 'no valid rmw_zenoh attachment' in caplog.text)
            assert sim.now() == Time(0)
    message.clock = Time.from_seconds(7).to_msg()
    clock.write(message)
    assert wait_for(lambda: sim.now() == Time.from_seconds(7))
    raw.undeclare()
