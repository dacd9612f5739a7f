"""``zros topic ...`` run as a user runs it, against a router in the test process."""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable, Iterator
from datetime import datetime, timezone
from typing import Any

import pytest
import zenoh

import zros
from tests.cli.conftest import Cli, publishing
from zros.testing import spinning, wait_for
from zros.transport import Router

Node = Callable[..., Any]


@pytest.fixture
def talker(zros_node: Node) -> Iterator[Callable[..., Any]]:
    """``start(topic, type, every=0.02, **fields)``: a node publishing one message over and over
    (rate-scheduled, so its mean rate is exact) until the test ends."""
    stops: list[threading.Event] = []
    threads: list[threading.Thread] = []

    def start(topic: str, type_name: str, hz: float = 50.0, **fields: Any) -> Any:
        node = zros_node('talker')
        publisher = node.create_publisher(type_name, topic, 10)
        message = zros.Message(type_name, **fields)
        stop = threading.Event()

        def loop() -> None:
            rate = node.create_rate(hz)
            while not stop.is_set():
                if hasattr(message, 'header'):
                    message.header.stamp = node.now().to_msg()
                publisher.write(message)
                rate.sleep()

        thread = threading.Thread(target=loop, daemon=True)
        thread.start()
        stops.append(stop)
        threads.append(thread)
        return publisher

    yield start
    for stop in stops:
        stop.set()
    for thread in threads:
        thread.join(5)


def test_list_info_type_find(cli: Cli, zros_node: Node) -> None:
    node = zros_node('graph_node', '/robot')
    node.create_publisher('std_msgs/msg/String', 'chatter', 10)
    node.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel', lambda m: None)
    other = zros_node('listener')
    other.create_subscription('std_msgs/msg/String', '/robot/chatter', lambda m: None)

    listing = cli.run('topic', 'list')
    assert listing.returncode == 0, listing.stderr
    assert {'/robot/chatter', '/cmd_vel'} <= set(listing.stdout.split())
    typed = cli.run('topic', 'list', '-t').stdout.splitlines()
    assert '/robot/chatter [std_msgs/msg/String]' in typed
    assert '/cmd_vel [geometry_msgs/msg/Twist]' in typed
    verbose = cli.run('topic', 'list', '-v').stdout
    published, subscribed = verbose.split('Subscribed topics:')
    assert ' * /robot/chatter [std_msgs/msg/String] 1 publisher' in published
    assert '/cmd_vel' not in published
    assert ' * /robot/chatter [std_msgs/msg/String] 1 subscriber' in subscribed
    assert ' * /cmd_vel [geometry_msgs/msg/Twist] 1 subscriber' in subscribed

    info = cli.run('topic', 'info', '/robot/chatter').stdout
    assert info.splitlines()[:5] == [
        'Type: std_msgs/msg/String',
        '',
        'Publisher count: 1',
        '',
        'Subscription count: 1',
    ]
    detailed = cli.run('topic', 'info', '/robot/chatter', '-v').stdout
    assert 'Node name: /robot/graph_node' in detailed
    assert 'Endpoint type: PUBLISHER' in detailed
    assert 'Node name: /listener' in detailed
    assert 'Endpoint type: SUBSCRIPTION' in detailed

    assert cli.run('topic', 'type', '/cmd_vel').stdout == 'geometry_msgs/msg/Twist\n'
    assert cli.run('topic', 'find', 'std_msgs/String').stdout == '/robot/chatter\n'


def test_unknown_topics_fail_with_exit_1(cli: Cli) -> None:
    for args in (('topic', 'info', '/nope'), ('topic', 'type', '/nope')):
        result = cli.run(*args)
        assert result.returncode == 1
        assert '/nope' in result.stderr
    echo = cli.run('topic', 'echo', '/nope', '--wait', '0.2')
    assert echo.returncode == 1
    assert 'topic /nope does not appear on the network' in echo.stderr
    usage = cli.run('topic', 'echo')
    assert usage.returncode == 2
    assert 'usage: zros topic echo' in usage.stderr


def test_echo_once_prints_yaml_like_ros2(cli: Cli, talker: Callable[..., Any]) -> None:
    talker('/pose', 'geometry_msgs/msg/Pose', position={'x': 1.5, 'y': -2.0})
    result = cli.run('topic', 'echo', '/pose', '--once')
    assert result.returncode == 0, result.stderr
    assert result.stdout == (
        'position:\n  x: 1.5\n  y: -2.0\n  z: 0.0\n'
        'orientation:\n  x: 0.0\n  y: 0.0\n  z: 0.0\n  w: 1.0\n---\n'
    )
    field = cli.run('topic', 'echo', '/pose', '--once', '--field', 'position.y')
    assert field.stdout == '-2.0\n---\n'
    csv = cli.run('topic', 'echo', '/pose', '--count', '2', '--csv')
    assert csv.stdout.splitlines() == ['1.5,-2.0,0.0,0.0,0.0,0.0,1.0'] * 2
    wrong = cli.run('topic', 'echo', '/pose', '--once', '--field', 'position.q')
    assert wrong.returncode == 1
    assert 'position.q' in wrong.stderr


def test_echo_abbreviates_arrays_and_strings(cli: Cli, talker: Callable[..., Any]) -> None:
    talker('/scan', 'sensor_msgs/msg/LaserScan', ranges=[1.0, 2.0, 3.0], angle_max=1.0)
    talker('/words', 'std_msgs/msg/String', data='x' * 40)
    no_arr = cli.run('topic', 'echo', '/scan', '--once', '--no-arr').stdout
    assert "ranges: '<sequence type: float, length: 3>'" in no_arr
    full = cli.run('topic', 'echo', '/scan', '--once', '--flow-style').stdout
    assert 'ranges: [1.0, 2.0, 3.0]' in full
    assert cli.run('topic', 'echo', '/words', '--once', '--no-str').stdout == (
        "data: '<string length: <40>>'\n---\n"
    )
    short = cli.run('topic', 'echo', '/words', '--once', '--truncate-length', '5').stdout
    assert short == 'data: xxxxx...\n---\n'


def test_echo_truncates_long_values_at_128_like_ros2(cli: Cli, zros_node: Node) -> None:
    # a 640x480 rgb8 image printed in full was 921,613 lines (43 s); ros2 cuts at 128 items
    node = zros_node('camera')
    node.create_publisher('sensor_msgs/msg/Image', '/image', 'latched').write(
        zros.Message(
            'sensor_msgs/msg/Image', height=480, width=640, encoding='rgb8', step=1920,
            data=bytes(640 * 480 * 3), header={'frame_id': 'f' * 200},
        )
    )  # fmt: skip
    started = time.monotonic()
    result = cli.run('topic', 'echo', '/image', '--once')
    assert result.returncode == 0, result.stderr
    assert time.monotonic() - started < 30
    lines = result.stdout.splitlines()
    data = lines.index('data:')
    assert lines[data + 1 : data + 3] == ['- 0', '- 0']
    assert lines[data + 129 :] == ["- '...'", '---']
    assert f'  frame_id: {"f" * 128}...' in lines
    short = cli.run('topic', 'echo', '/image', '--once', '--field', 'data', '-l', '5').stdout
    assert short == '- 0\n' * 5 + "- '...'\n---\n"
    frame = cli.run('topic', 'echo', '/image', '--once', '--field', 'header.frame_id').stdout
    assert frame == f'{"f" * 128}...\n---\n'
    csv = cli.run('topic', 'echo', '/image', '--once', '--csv', '--truncate-length', '2').stdout
    assert csv == '0,0,ff...,480,640,rg...,0,1920,0,0,...\n'
    for full in ('-f', '--full-length'):
        whole = cli.run('topic', 'echo', '/image', '--once', '--field', 'header.frame_id', full)
        assert whole.stdout == f'{"f" * 200}\n---\n'
    negative = cli.run('topic', 'echo', '/image', '--truncate-length', '-1')
    assert negative.returncode == 2
    assert 'must be 0 or more, not -1' in negative.stderr


def test_echo_receives_a_latched_message(cli: Cli, zros_node: Node) -> None:
    node = zros_node('static')
    node.create_publisher('std_msgs/msg/String', '/map_name', 'latched').write(
        zros.Message('std_msgs/msg/String', data='office')
    )
    result = cli.run('topic', 'echo', '/map_name', '--once')
    assert result.stdout == 'data: office\n---\n'


def test_pub_reaches_a_subscriber(cli: Cli, zros_node: Node) -> None:
    node = zros_node('listener')
    received: list[Any] = []
    node.create_subscription('geometry_msgs/msg/Twist', '/cmd_vel', received.append)
    with spinning(node):
        result = cli.run(
            'topic', 'pub', '/cmd_vel', 'geometry_msgs/Twist',
            '{linear: {x: 0.5}, angular: {z: -1}}', '--once', '-w', '1',
        )  # fmt: skip
        assert result.returncode == 0, result.stderr
        assert wait_for(lambda: received, 10)
    assert received[0].linear.x == 0.5
    assert received[0].angular.z == -1.0
    assert 'publishing #1: geometry_msgs.msg.Twist(' in result.stdout
    assert len(received) == 1


def test_pub_at_a_rate_and_latched(cli: Cli, zros_node: Node) -> None:
    node = zros_node('listener')
    stamps: list[float] = []
    node.create_subscription(
        'std_msgs/msg/Int32', '/count', lambda m: stamps.append(time.monotonic())
    )
    with spinning(node):
        result = cli.run('topic', 'pub', '/count', 'std_msgs/msg/Int32', '{data: 7}', '-r', '20',
                         '-t', '5', '-w', '1')  # fmt: skip
        assert result.returncode == 0, result.stderr
        assert wait_for(lambda: len(stamps) == 5, 10)
    assert 0.15 < stamps[-1] - stamps[0] < 0.6  # 4 gaps of 50 ms
    latched = cli.start('topic', 'pub', '/level', 'std_msgs/msg/Int32', '{data: 3}', '--once',
                        '--latched', '--keep-alive', '30')  # fmt: skip
    latched.wait_line(lambda line: line.startswith('publishing #1'))
    late = zros_node('late')
    got = late.create_subscription('std_msgs/msg/Int32', '/level', qos='latched')
    assert got.wait_for_message(timeout=10).data == 3
    latched.process.terminate()


def test_pub_stamps_header_auto_and_time_now_anew_each_message(cli: Cli, zros_node: Node) -> None:
    # as ros2 topic pub: {header: auto} is a Header stamped now, {stamp: now} a Time of now
    node = zros_node('listener')
    poses: list[Any] = []
    headers: list[Any] = []
    markers: list[Any] = []
    node.create_subscription('geometry_msgs/msg/PoseStamped', '/pose', poses.append)
    node.create_subscription('std_msgs/msg/Header', '/header', headers.append)
    node.create_subscription('visualization_msgs/msg/MarkerArray', '/markers', markers.append)
    with spinning(node):
        before = time.time()
        for topic, type_name, values in (
            ('/pose', 'geometry_msgs/msg/PoseStamped', '{header: auto, pose: {position: {x: 1}}}'),
            ('/header', 'std_msgs/msg/Header', '{stamp: now, frame_id: auto}'),
            ('/markers', 'visualization_msgs/msg/MarkerArray',
             '{markers: [{header: auto}, {header: {stamp: now, frame_id: map}}]}'),
        ):  # fmt: skip
            result = cli.run('topic', 'pub', topic, type_name, values, '-r', '20', '-t', '3',
                             '-w', '1')  # fmt: skip
            assert result.returncode == 0, result.stderr
        assert wait_for(lambda: len(poses) == len(headers) == len(markers) == 3, 10)
        after = time.time()

    def seconds(stamp: Any) -> float:
        return float(stamp.sec + stamp.nanosec * 1e-9)

    pose_stamps = [seconds(p.header.stamp) for p in poses]
    assert all(before <= t <= after for t in pose_stamps), (before, pose_stamps, after)
    assert pose_stamps == sorted(set(pose_stamps))  # each message stamped anew
    assert [(p.header.frame_id, p.pose.position.x) for p in poses] == [('', 1.0)] * 3
    assert [h.frame_id for h in headers] == ['auto'] * 3  # only a Header field expands 'auto'
    assert all(before <= seconds(h.stamp) <= after for h in headers)
    for array in markers:
        first, second = array.markers
        assert (first.header.frame_id, second.header.frame_id) == ('', 'map')
        assert before <= seconds(first.header.stamp) == seconds(second.header.stamp) <= after


def test_pub_once_waits_for_a_subscriber_unless_w_0_like_ros2(cli: Cli, zros_node: Node) -> None:
    # ros2 topic pub: -1 and -t wait for 1 matching subscription (-w N for N), without end
    # unless --max-wait-time-secs; -w 0 does not wait at all
    waiting = cli.start('topic', 'pub', '/late', 'std_msgs/msg/Int32', '{data: 4}', '-1')
    waiting.wait_line(lambda line: line == 'Waiting for at least 1 matching subscription(s)...')
    node = zros_node('listener')
    received: list[Any] = []
    node.create_subscription('std_msgs/msg/Int32', '/late', received.append)
    with spinning(node):
        code, _ = waiting.finish()
        assert code == 0, waiting.errors.text()
        assert wait_for(lambda: received, 10)
    assert [m.data for m in received] == [4]

    def fastest(*args: str) -> float:  # the fastest of three runs: load on the machine varies
        times = []
        for _ in range(3):
            started = time.monotonic()
            result = cli.run(*args)
            times.append(time.monotonic() - started)
            assert result.returncode == 0, result.stderr
        return min(times)

    # a command that opens a node, asks the graph and ends, as pub does without waiting
    baseline = fastest('topic', 'find', 'std_msgs/msg/Int32')
    unwaited = fastest(
        'topic', 'pub', '/nobody', 'std_msgs/msg/Int32', '{data: 1}', '-1', '-w', '0'
    )
    assert unwaited < baseline + 0.8, (unwaited, baseline)  # it was baseline + 1.3 s

    timed_out = cli.run('topic', 'pub', '/nobody', 'std_msgs/msg/Int32', '{data: 1}', '-t', '2',
                        '--max-wait-time-secs', '0.3')  # fmt: skip
    assert timed_out.returncode == 1
    assert timed_out.stderr == (
        'zros: error: /nobody: 0 of the 1 subscriber(s) waited for showed within 0.3 s\n'
    )
    assert 'publishing' not in timed_out.stdout
    useless = cli.run('topic', 'pub', '/nobody', 'std_msgs/msg/Int32', '{data: 1}', '-w', '0',
                      '--max-wait-time-secs', '1')  # fmt: skip
    assert useless.returncode == 2
    assert '--max-wait-time-secs needs a subscriber to wait for' in useless.stderr


def test_pub_rejects_bad_values_before_publishing(cli: Cli) -> None:
    # mistakes in what was typed are usage errors (exit 2), one line naming the field
    for type_name, values, expected in (
        ('std_msgs/msg/Int32', '{data: [1, 2', 'not valid YAML'),
        ('std_msgs/msg/Int32', '[1, 2]', 'must be a YAML mapping'),
        (
            'std_msgs/msg/String',
            '{dat: hi}',
            "std_msgs/msg/String has no field 'dat' (did you mean 'data'? fields: data)",
        ),
        (
            'std_msgs/msg/Float32',
            '{data: abc}',
            "std_msgs/msg/Float32 field 'data': expected a float for float32, got str 'abc'",
        ),
        (
            'geometry_msgs/msg/PoseStamped',
            '{pose: {position: {xx: 1}}}',
            "geometry_msgs/msg/PoseStamped has no field 'pose.position.xx' (did you mean "
            "'pose.position.x'? fields of geometry_msgs/msg/Point: x, y, z)",
        ),
        (
            'std_msgs/msg/UInt8',
            '{data: 300}',
            "std_msgs/msg/UInt8: field 'data': 300 is out of the range of uint8 [0, 255]",
        ),
    ):
        result = cli.run('topic', 'pub', '/x', type_name, values, '--once')
        assert result.returncode == 2, result.stderr
        assert expected in result.stderr
        assert len(result.stderr.splitlines()) == 1, result.stderr
        assert 'publishing' not in result.stdout
    result = cli.run('topic', 'pub', '/x', 'std_srvs/srv/SetBool', '{}', '--once')
    assert result.returncode == 1
    assert 'is not a message type' in result.stderr


def test_hz_reports_a_50_hz_publisher_within_5_percent(
    cli: Cli, talker: Callable[..., Any]
) -> None:
    talker('/fast', 'std_msgs/msg/Int32', hz=50.0, data=1)
    running = cli.start('topic', 'hz', '/fast', '--period', '2', '--count', '2')
    running.wait_line(lambda line: line.startswith('average rate:'))
    rate_line = running.wait_line(lambda line: line.startswith('average rate:'))
    stats = running.wait_line(lambda line: 'std dev' in line)
    code, _ = running.finish()
    assert code == 0
    rate = float(rate_line.split(':')[1])
    assert abs(rate - 50.0) / 50.0 < 0.05, rate_line
    match = re.fullmatch(r'\tmin: (\S+)s max: (\S+)s std dev: (\S+)s window: (\d+)', stats)
    assert match is not None, stats
    assert float(match[1]) <= 0.02 <= float(match[2])
    assert int(match[4]) > 50


def test_bw_reports_message_sizes(cli: Cli, talker: Callable[..., Any]) -> None:
    talker('/blob', 'std_msgs/msg/UInt8MultiArray', hz=50.0, data=bytes(2000))
    running = cli.start('topic', 'bw', '/blob', '--period', '1', '--count', '2')
    running.wait_line(lambda line: line.startswith('Subscribed to [/blob]'))
    running.wait_line(lambda line: line.endswith('messages'))
    sizes = running.wait_line(lambda line: 'Message size mean' in line)
    # 2000 bytes of data, sequence lengths and the 4-byte CDR header
    assert sizes.strip() == 'Message size mean: 2.02 KB min: 2.02 KB max: 2.02 KB'
    assert running.finish()[0] == 0


@pytest.mark.parametrize(('verb', 'report'), [('hz', 'average rate:'), ('delay', 'average delay:')])
def test_hz_and_delay_say_no_new_messages_once_the_publisher_stops(
    cli: Cli, zros_node: Node, verb: str, report: str
) -> None:
    talker = zros_node('talker')
    publisher = talker.create_publisher('geometry_msgs/msg/PointStamped', '/stopping')
    message = publisher.msg_type()
    message.header.stamp = talker.now().to_msg()
    running = cli.start('topic', verb, '/stopping', '--period', '0.3')
    with publishing(talker, publisher, message):
        running.wait_line(lambda line: line.startswith(report))
    # not the last window over and over, as ros2 topic hz and delay
    running.wait_line(lambda line: line == 'no new messages', 10)


def _bytes_per_second(line: str) -> float:
    value, unit = line.split()[:2]
    return float(value) * {'B/s': 1, 'KB/s': 1e3, 'MB/s': 1e6}[unit]


def test_bw_decays_once_the_publisher_stops(cli: Cli, zros_node: Node) -> None:
    talker = zros_node('talker')
    publisher = talker.create_publisher('std_msgs/msg/UInt8MultiArray', '/stopping')
    message = zros.Message('std_msgs/msg/UInt8MultiArray', data=bytes(2000))
    running = cli.start('topic', 'bw', '/stopping', '--period', '0.3')
    with publishing(talker, publisher, message):
        running.wait_line(lambda line: line.endswith(' messages'))
    # the first report after the stop may still count the last messages; from the next on
    # the rate falls, as ros2 topic bw's (divided by the time up to now)
    running.wait_line(lambda line: line.endswith(' messages'))
    rates = [
        _bytes_per_second(running.wait_line(lambda line: line.endswith(' messages'), 10))
        for _ in range(2)
    ]
    assert rates[1] < rates[0], rates


def test_delay_from_header_stamps(cli: Cli, talker: Callable[..., Any]) -> None:
    talker('/imu', 'sensor_msgs/msg/Imu', hz=50.0)
    running = cli.start('topic', 'delay', '/imu', '--period', '1', '--count', '1')
    line = running.wait_line(lambda line: line.startswith('average delay:'))
    assert 0.0 <= float(line.split(':')[1]) < 0.5
    assert running.finish()[0] == 0
    no_header = cli.run('topic', 'delay', '/x', 'std_msgs/msg/String', '--count', '1')
    assert no_header.returncode == 1
    assert 'std_msgs/msg/String has no header' in no_header.stderr


def test_list_on_a_graph_larger_than_zenoh_channels(cli: Cli, zros_node: Node) -> None:
    """More tokens than a default Zenoh channel holds (256) used to stall the session."""
    node = zros_node('crowd', enable_rosout=False, start_parameter_services=False)
    for index in range(300):
        node.create_publisher('std_msgs/msg/Empty', f'/crowd/t{index:03d}', 1)
    listing = cli.run('topic', 'list', timeout=30)
    assert listing.returncode == 0, listing.stderr
    assert [name for name in listing.stdout.split() if name.startswith('/crowd/')] == [
        f'/crowd/t{index:03d}' for index in range(300)
    ]


def test_pub_sends_with_the_priority_and_congestion_asked(cli: Cli, zros_router: Router) -> None:
    samples: list[zenoh.Sample] = []
    taps = [zros_router.session.declare_subscriber(key, samples.append) for key in ('a', 'b')]
    chosen_options = ('--priority', 'background', '--no-express', '--congestion', 'block')
    for topic, options in (('/a', ()), ('/b', chosen_options)):
        result = cli.run(
            # -w 0: the router's taps are no ROS subscribers for --once to wait for
            'topic',
            'pub',
            topic,
            'std_msgs/msg/Int32',
            '{data: 1}',
            '--once',
            '-w',
            '0',
            *options,
        )
        assert result.returncode == 0, result.stderr
    assert wait_for(lambda: len(samples) == 2, 10)
    for tap in taps:
        tap.undeclare()
    default, chosen = sorted(samples, key=lambda s: str(s.key_expr))
    assert default.priority == zenoh.Priority.DATA
    assert default.congestion_control == zenoh.CongestionControl.DROP
    assert chosen.priority == zenoh.Priority.BACKGROUND and not chosen.express
    assert chosen.congestion_control == zenoh.CongestionControl.BLOCK
    wrong = cli.run('topic', 'pub', '/a', 'std_msgs/msg/Int32', '{}', '--once', '--priority', '9')
    assert wrong.returncode == 2 and "invalid choice: '9'" in wrong.stderr


def test_echo_and_hz_with_max_age_drop_stale_messages_and_say_so(
    cli: Cli, zros_router: Router
) -> None:
    session = zros_router.session
    stamp_id = zenoh.TimestampId(bytes(session.zid()))

    def put(publisher: zenoh.Publisher, value: str, age: float) -> None:
        when = datetime.fromtimestamp(time.time() - age, timezone.utc)
        payload = zros.cdr.encode(zros.Message('std_msgs/msg/String', data=value))
        publisher.put(payload, timestamp=zenoh.Timestamp(when, stamp_id))

    publisher = session.declare_publisher('chatter')
    echo = cli.start('topic', 'echo', '/chatter', 'std_msgs/msg/String', '--max-age', '0.5',
                     '--count', '1')  # fmt: skip
    assert wait_for(lambda: publisher.matching_status.matching, 10)
    put(publisher, 'stale', 3.0)
    put(publisher, 'fresh', 0.0)
    assert echo.wait_line(lambda line: line.startswith('data:')) == 'data: fresh'
    assert echo.finish()[0] == 0
    assert 'past its lifespan of 0.5 s' in echo.errors.text()
    wrong = cli.run('topic', 'hz', '/chatter', '--max-age', '0')
    assert wrong.returncode == 2 and 'a number of seconds > 0, not 0' in wrong.stderr
