"""ROS logging: console format, /rosout records, thresholds, once/throttle, Python logging."""

from __future__ import annotations

import inspect
import logging
import os
import re
import subprocess
import sys
from collections.abc import Callable

import pytest

import zros
from zros.node import Node
from zros.runtime.logger import INFO, RosFormatter, level_from_args, parse_level
from zros.testing import wait_for

LOG = 'rcl_interfaces/msg/Log'


def test_console_line_format() -> None:
    record = logging.LogRecord('ros.talker', INFO, 'x.py', 3, 'Publishing: "Hello"', None, None)
    record.ros_stamp = 1740933158_226629828
    record.ros_name = 'robot.talker'
    assert RosFormatter().format(record) == (
        '[INFO] [1740933158.226629828] [robot.talker]: Publishing: "Hello"'
    )


def test_console_output_of_a_script() -> None:
    result = subprocess.run(
        [sys.executable, '-c', 'import zros; zros.warn("low battery"); zros.debug("hidden")'],
        capture_output=True, text=True, timeout=60, check=False,
        env={**os.environ, 'ZROS_LOG_LEVEL': 'info'},
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert re.fullmatch(r'\[WARN\] \[\d+\.\d{9}\] \[zros\]: low battery\n', result.stderr)


def test_records_reach_rosout_with_their_origin(zros_node: Callable[..., Node]) -> None:
    talker = zros_node('talker', '/robot')
    listener = zros_node('monitor')
    rosout = listener.create_subscription(LOG, '/rosout', qos='rosout')
    logger = talker.get_logger()
    line = inspect.currentframe().f_lineno + 1  # type: ignore[union-attr]
    logger.warn('battery at 20 %')
    assert wait_for(rosout.has_new_message)
    record = rosout.read_message()
    assert record.level == 30 and record.msg == 'battery at 20 %'
    assert record.name == 'robot.talker'
    assert record.file == __file__
    assert record.function == 'test_records_reach_rosout_with_their_origin'
    assert record.line == line
    stamp = zros.Time.from_msg(record.stamp)
    assert abs(stamp.seconds - talker.now().seconds) < 5
    # /rosout is transient local: a late subscriber still gets what was logged
    late = zros_node('late').create_subscription(LOG, '/rosout', qos='rosout')
    assert wait_for(late.has_new_message)
    assert late.read_message().msg == 'battery at 20 %'


def test_threshold_from_argument_arguments_and_environment(
    zros_node: Callable[..., Node], monkeypatch: pytest.MonkeyPatch
) -> None:
    assert not zros_node('quiet').get_logger().debug('hidden')
    assert zros_node('loud', log_level='debug').get_logger().debug('shown')
    from_args = zros_node('args', args=['--ros-args', '--log-level', 'error'])
    assert not from_args.get_logger().warn('hidden')
    assert from_args.get_logger().error('shown')
    monkeypatch.setenv('ZROS_LOG_LEVEL', 'DEBUG')
    assert zros_node('env').get_logger().debug('shown')
    logger = zros_node('child').get_logger().get_child('driver')
    assert logger.name == 'child.driver'
    logger.set_level('fatal')
    assert not logger.error('hidden') and logger.fatal('shown')
    assert level_from_args(['--ros-args', '--log-level', 'warn']) == 30
    with pytest.raises(ValueError, match='unknown log level'):
        parse_level('loud')


def test_once_throttle_and_skip_first(zros_node: Callable[..., Node]) -> None:
    logger = zros_node('repeater').get_logger()
    assert [logger.info('once', once=True) for _ in range(3)] == [True, False, False]
    assert [logger.info('skip', skip_first=True) for _ in range(3)] == [False, True, True]
    throttled = [logger.info('tick', throttle=3600.0) for _ in range(5)]
    assert throttled == [True, False, False, False, False]


def test_python_logging_both_ways(zros_node: Callable[..., Node]) -> None:
    node = zros_node('bridge')
    monitor = zros_node('monitor').create_subscription(LOG, '/rosout', qos='rosout')
    captured: list[logging.LogRecord] = []

    class Capture(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            captured.append(record)

    ros_logger = logging.getLogger('ros')
    capture = Capture()
    ros_logger.addHandler(capture)
    library = logging.getLogger('some_library')
    handler = zros.RosoutHandler(node)
    library.addHandler(handler)
    library.setLevel(logging.INFO)
    try:
        node.get_logger().error('from zros')  # zros -> Python logging
        library.info('from a library')  # Python logging -> /rosout
    finally:
        ros_logger.removeHandler(capture)
        library.removeHandler(handler)
    assert [(r.name, r.getMessage(), r.levelno) for r in captured] == [
        ('ros.bridge', 'from zros', logging.ERROR)
    ]
    assert captured[0].ros_stamp > 0  # type: ignore[attr-defined]
    assert wait_for(lambda: monitor.received >= 2)
    records = {m.msg: m for m in monitor.take()}
    assert records['from a library'].name == 'some_library'
    assert records['from a library'].level == 20
    assert records['from zros'].name == 'bridge'


def test_module_level_logging_uses_the_default_node(
    zros_router: zros.transport.Router, zros_node: Callable[..., Node]
) -> None:
    monitor = zros_node('monitor').create_subscription(LOG, '/rosout', qos='rosout')
    zros.init('R_demo', connect=zros_router.endpoint, handle_sigint=False)
    try:
        zros.info('0.8 V')
        zros.log('odd reading', 'warn')
        assert wait_for(lambda: monitor.received >= 2)
        assert [(m.name, m.level, m.msg) for m in monitor.take()] == [
            ('R_demo', 20, '0.8 V'),
            ('R_demo', 30, 'odd reading'),
        ]
    finally:
        zros.shutdown()
