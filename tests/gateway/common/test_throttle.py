"""Per-topic rate limits of what a gateway sends (``--throttle '/camera/.*=2'``)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import pytest

import zros
from tests.cli.conftest import ZROS, Cli
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.throttle import Throttle
from zros.gateway.common.watched_topics import Taps
from zros.pubsub.taps import graph_topics
from zros.testing import wait_for
from zros.transport import Router

Make = Callable[..., Any]


def test_a_throttled_topic_passes_one_message_per_period_on_schedule() -> None:
    throttle = Throttle.parse(['/camera/.*=2', '/camera/info=100', '/tf=50'])
    assert throttle.rate('/camera/info') == 2  # the first rule that matches
    assert throttle.rate('/camera') is None  # whole names only
    assert throttle.rate('/tf') == 50 and throttle.rate('/tf_static') is None
    now = [0.0]
    passed: list[int] = []
    deliver = throttle.limit(
        '/camera/image', lambda data, stamp: passed.append(data), lambda: now[0]
    )
    for frame in range(31):  # 10 Hz for 3 s
        now[0] = frame / 10
        deliver(frame, 0)
    assert passed == [0, 5, 10, 15, 20, 25, 30]  # 2 Hz, every fifth frame
    now[0] = 10.0  # after a pause the schedule starts again from the next message
    deliver(100, 0)
    now[0] = 10.2
    deliver(102, 0)
    assert passed[-2:] == [30, 100]

    def deliver_all(data: int, stamp: int) -> None:
        passed.append(data)

    assert throttle.limit('/odom', deliver_all) is deliver_all  # no rule: nothing in between


@pytest.mark.parametrize(
    ('spec', 'error'),
    [
        ('/camera', 'REGEX=HZ with HZ > 0'),
        ('/camera=0', 'REGEX=HZ with HZ > 0'),
        ('=2', 'REGEX=HZ with HZ > 0'),
        ('/camera=fast', 'REGEX=HZ with HZ > 0'),
        ('[=2', "--throttle '\\[': not a regular expression"),
    ],
)
def test_a_wrong_rule_is_refused_with_what_was_given(spec: str, error: str) -> None:
    with pytest.raises(GatewayError, match=error):
        Throttle.parse([spec])


def test_taps_deliver_a_throttled_topic_at_its_rate(zros_node: Make) -> None:
    talker, watcher = zros_node('talker'), zros_node('watcher')
    fast = talker.create_publisher('std_msgs/msg/Int32', '/fast')
    other = talker.create_publisher('std_msgs/msg/Int32', '/other')
    assert watcher.graph.wait_until(lambda: {'/fast', '/other'} <= set(graph_topics(watcher)), 10)
    topics = graph_topics(watcher)
    taps = Taps(watcher, limit=Throttle.parse(['/fast=5']).limit)
    got: dict[str, list[bytes]] = {'/fast': [], '/other': []}
    try:
        for name in got:
            taps.watch(topics[name], 'client', lambda data, stamp, n=name: got[n].append(data))
        assert fast.wait_for_subscribers(10) and other.wait_for_subscribers(10)
        start = time.monotonic()
        for number in range(50):  # 50 Hz for a second
            for publisher in (fast, other):
                publisher.write(zros.Message('std_msgs/msg/Int32', data=number))
            time.sleep(max(0.0, start + (number + 1) * 0.02 - time.monotonic()))
        assert wait_for(lambda: len(got['/other']) == 50, 10)
        assert 4 <= len(got['/fast']) <= 7, len(got['/fast'])  # 5 a second, the first at once
        assert taps.counts('/fast')[0] == 50  # all received, most not sent on
    finally:
        taps.close()


@pytest.mark.parametrize('command', ['foxglove', 'rosbridge'])
def test_the_gateway_commands_refuse_a_wrong_throttle(zros_router: Router, command: str) -> None:
    if ZROS is None:
        pytest.skip('the zros console script is not installed in this environment')
    result = Cli(zros_router.endpoint).run(command, '--port', '0', '--throttle', '/camera/.*=0')
    assert result.returncode == 1
    assert "--throttle takes REGEX=HZ with HZ > 0, as '/camera/.*=2', not '/camera/.*=0'" in (
        result.stderr
    )
