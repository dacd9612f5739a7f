"""Every script in examples/ runs, on its own and against a router shared by several processes.

Each script is run as a user runs it: ``python examples/<script>.py`` in a fresh process, with no
``ZROS_CONNECT``, so it starts a router of its own; its output must show that it did its job.
A new script fails ``test_every_example_has_expectations`` until its expected output is added
here, so no example can skip CI. The pairs (talker and listeners, service and action servers
and clients, the sensor and the tutorial's node) then run in two processes through the
``zros_router`` fixture.
"""

from __future__ import annotations

import os
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import zros
from zros.node import Node
from zros.testing import spinning
from zros.transport import Router

EXAMPLES = Path(__file__).resolve().parent.parent / 'examples'
DOCS = Path(__file__).resolve().parent.parent / 'docs'
#: the scripts (``_bootstrap.py`` is the start they share, not one of them)
SCRIPTS = sorted(path.name for path in EXAMPLES.glob('*.py') if not path.name.startswith('_'))
TIMEOUT = 90.0  # seconds for one script, on a loaded 2-core machine

#: the arguments a script that runs until Ctrl-C gets to end by itself here
ARGS: dict[str, tuple[str, ...]] = {
    'talker.py': ('--count', '10'),
    'listener_polling.py': ('--count', '5'),
    'listener_callback.py': ('--count', '5'),
    'asyncio_subscriber.py': ('--count', '5'),
}

#: what each script prints when it runs on its own (regular expressions, all must match)
EXPECTED: dict[str, list[str]] = {
    'sharp_sensor.py': [r'published 554 messages'],
    'rosr_demo0_log.py': [r'logged [1-9]\d* voltage readings'],
    'rosr_demo1_plot.py': [r'plotted 314 readings into rosr_demo1\.png'],
    'rosr_demo2_fit.py': [r'fitted dist ~ poly\(volt, 8\) to 240 pairs', r'0\.8 V -> 0\.1\d\d m'],
    'rosr_demo3_range.py': [
        r'published 314 sensor_msgs/Range on /sharpGP2D120/Distance; read back 314'
    ],
    'talker.py': [r'Publishing: "Hello World: 9"'],
    'listener_polling.py': [r'I heard: "Hello World: \d+"', r'heard 5 messages'],
    'listener_callback.py': [r'I heard: "Hello World: \d+"', r'heard 5 messages'],
    'asyncio_subscriber.py': [r'heard 5 messages in an asyncio loop'],
    'add_two_ints_server.py': [r'Incoming request: a=40 b=2', r'the client got 42', r'answered 3'],
    'add_two_ints_client.py': [r'2 \+ 3 = 5', r'and asynchronously: \[0, 2, 4\]'],
    'fibonacci_action_server.py': [r'the client got \[0, 1, 1, 2, 3, 5, 8, 13, 21\] \(SUCCEEDED\)'],
    'fibonacci_action_client.py': [
        r'Feedback: \[0, 1, 1, 2\]',
        r'Result: \[0, 1, 1, 2, 3, 5, 8, 13, 21, 34, 55\] \(SUCCEEDED\)',
        r'The long goal ended CANCELED',
    ],
    'parameters.py': [
        r'speed=0\.8 \(file\), wheels\.radius=0\.06 \(command line\)',
        r'the driver now has 1\.5',
        r"Parameter \{speed\} doesn't comply with floating point range",
        r'cannot be set because it is read-only',
        r'a wheel radius must be positive',
        r"parameter events from /driver: \[\"/driver: \{'speed': 1\.5\}\"\]",
        r'gain = 3 of type integer',
        r'ros__parameters:',
    ],
    'wan_tls.py': [
        r'connected as a Zenoh client: True',
        r'laptop <- robot: battery at 24\.3 V, 87%',
        r'laptop -> robot: cmd_vel linear\.x = 0\.2',
        r'requires a client certificate \(mutual TLS\)',
    ],
    'bag_to_numpy.py': [
        r'recorded 554 messages into sharp_sensor_bag/',
        r'/sharpGP2D120/Voltage: 314 x std_msgs/msg/Float32',
        r"calibration: a structured array of 240 records, fields \('time', 'dist', 'volt'\)",
        r'fitted from the bag: 0\.8 V -> 0\.1[56]\d m',
        r'bag_read: 240 rows',
        r'fitted distance \[m\] over time into bag_to_numpy\.png',
    ],
    'real_robot.py': [r'No bridge answered at tcp/127\.0\.0\.1:7447|connected to tcp/127\.0\.0\.1'],
    'robot_path.py': [
        r'Frame base_laser exists with parent base_link\.',
        r'Frame odom exists with parent map\.',
        r'path of base_laser in map: 401 poses over 20\.0 s',
        r'     10\.00      0\.900      4\.500       180\.0',
        r'drove 12\.63 m',
        r'drew the path into robot_path\.png',
    ],
}


def environment() -> dict[str, str]:
    """This process's environment without zros or Zenoh settings: scripts start on their own."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(('ZROS_', 'ZENOH_'))}
    env['MPLBACKEND'] = 'Agg'
    env['PYTHONUNBUFFERED'] = '1'
    return env


def run(script: str, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        cwd=cwd,
        env=environment(),
        check=False,
    )


def check_output(output: str, patterns: list[str]) -> None:
    for pattern in patterns:
        assert re.search(pattern, output), f'{pattern!r} not in the output:\n{output}'


def test_every_example_has_expectations() -> None:
    assert SCRIPTS, f'no scripts in {EXAMPLES}'
    assert set(SCRIPTS) == set(EXPECTED), 'add the expected output of new examples to EXPECTED'


@pytest.mark.parametrize('script', SCRIPTS)
def test_example_runs_on_its_own(script: str, tmp_path: Path) -> None:
    if script == 'wan_tls.py':
        pytest.importorskip('cryptography', reason='wan_tls.py needs the tls extra')
    result = run(script, *ARGS.get(script, ()), cwd=tmp_path)
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    check_output(result.stdout, EXPECTED.get(script, []))
    assert 'Traceback' not in result.stderr, result.stderr


def test_bag_to_numpy_keeps_the_bag_it_names(tmp_path: Path) -> None:
    from zros.bag import Bag

    first = run('bag_to_numpy.py', cwd=tmp_path)
    assert first.returncode == 0, first.stdout + first.stderr
    bag = tmp_path / 'sharp_sensor_bag'
    with Bag(bag) as recording:  # the folder it printed is still there, whole
        assert recording.message_count == 554
    again = run('bag_to_numpy.py', cwd=tmp_path)
    assert again.returncode == 0, again.stdout + again.stderr
    assert 'reading sharp_sensor_bag/, recorded before' in again.stdout
    assert 'recorded 554' not in again.stdout
    check_output(again.stdout, [r'fitted from the bag: 0\.8 V -> 0\.1[56]\d m'])


def docs_blocks() -> list[tuple[str, str]]:
    """``(page:line, code)`` of every Python block in docs/, but those marked ``<!-- not run``
    and those docs/generate.py wrote (signatures, and the examples' sources run above)."""
    blocks = []
    for page in sorted(DOCS.rglob('*.md')):
        text = re.sub(
            r'<!-- generate: .*?<!-- end generate -->',
            lambda generated: '\n' * generated.group(0).count('\n'),  # the same line numbers
            page.read_text(),
            flags=re.S,
        )
        for match in re.finditer(
            r'(?:^(<!-- not run[^\n]*)\n)?^```python\n(.*?)^```', text, re.M | re.S
        ):
            if match.group(1) is None:
                line = text.count('\n', 0, match.start()) + 1
                blocks.append((f'{page.relative_to(DOCS)}:{line}', match.group(2)))
    return blocks


DOCS_BLOCKS = docs_blocks()


@pytest.mark.parametrize('code', [code for _, code in DOCS_BLOCKS], ids=[i for i, _ in DOCS_BLOCKS])
def test_docs_python_blocks_run(code: str, tmp_path: Path) -> None:
    """The documentation's Python examples run as written (tests through pytest)."""
    script = tmp_path / ('test_docs_block.py' if 'def test_' in code else 'docs_block.py')
    script.write_text(code)
    command = [sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider', str(script)]
    result = subprocess.run(
        command if 'def test_' in code else [sys.executable, str(script)],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        cwd=tmp_path,
        env=environment(),
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.strip(), 'a documentation example prints what it shows'


def test_the_fit_matches_the_paper(tmp_path: Path) -> None:
    """The acceptance of the tutorial: within 10 % of 0.164 m at 0.8 V and 0.061 m at 2.0 V."""
    result = run('rosr_demo2_fit.py', cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    fitted = dict(re.findall(r'(\d\.\d) V -> (\d\.\d+) m', result.stdout))
    assert fitted.keys() == {'0.8', '2.0'}, result.stdout
    assert float(fitted['0.8']) == pytest.approx(0.164, rel=0.1)
    assert float(fitted['2.0']) == pytest.approx(0.061, rel=0.1)
    assert (tmp_path / 'rosr_demo2.png').read_bytes().startswith(b'\x89PNG')


def test_the_live_plot_is_a_png(tmp_path: Path) -> None:
    result = run('rosr_demo1_plot.py', '--output', 'voltage.png', cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    assert (tmp_path / 'voltage.png').read_bytes().startswith(b'\x89PNG')


# --- two processes through one router --------------------------------------------------------


class Background:
    """A script running in the background, its output collected line by line."""

    def __init__(self, script: str, *args: str, cwd: Path) -> None:
        self.process = subprocess.Popen(
            [sys.executable, str(EXAMPLES / script), *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            cwd=cwd,
            env=environment(),
        )
        self.lines: queue.Queue[str] = queue.Queue()
        self.output: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.put(line)

    def wait_for(self, text: str, timeout: float = 30.0) -> bool:
        """Wait until a line containing ``text`` was printed."""
        deadline = time.monotonic() + timeout
        while not any(text in line for line in self.output):
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            try:
                self.output.append(self.lines.get(timeout=remaining))
            except queue.Empty:
                return False
        return True

    def finish(self, timeout: float = TIMEOUT) -> tuple[int, str]:
        """Wait for the script to end; its exit code and whole output."""
        try:
            code = self.process.wait(timeout)
        finally:
            self.stop()
        self._reader.join(10)  # it ends at the end of the output
        while not self.lines.empty():
            self.output.append(self.lines.get_nowait())
        return code, ''.join(self.output)

    def stop(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait(10)


@pytest.fixture
def background(tmp_path: Path) -> Iterator[Callable[..., Background]]:
    started: list[Background] = []

    def start(script: str, *args: str) -> Background:
        process = Background(script, *args, cwd=tmp_path)
        started.append(process)
        return process

    yield start
    for process in started:
        process.stop()


@pytest.mark.parametrize(
    'listener', ['listener_polling.py', 'listener_callback.py', 'asyncio_subscriber.py']
)
def test_talker_and_listener_in_two_processes(
    listener: str, zros_router: Router, background: Callable[..., Background], tmp_path: Path
) -> None:
    endpoint = zros_router.endpoint
    ear = background(listener, '--connect', endpoint, '--count', '5')
    assert ear.wait_for('listening on /chatter'), ''.join(ear.output)
    talker = run('talker.py', '--connect', endpoint, '--count', '30', cwd=tmp_path)
    assert talker.returncode == 0, talker.stdout + talker.stderr
    check_output(talker.stdout, ['a listener is here', r'Publishing: "Hello World: 29"'])
    code, output = ear.finish()
    assert code == 0, output
    assert 'no robot given' not in output
    check_output(output, [r'I heard: "Hello World: \d+"', r'heard 5 messages'])


@pytest.mark.parametrize(
    ('script', 'line'),
    [
        ('talker.py', 'Hello World: 15'),
        ('listener_polling.py', 'I heard: "Hello World: 15"'),
        ('listener_callback.py', 'I heard: "Hello World: 15"'),
        ('asyncio_subscriber.py', 'I heard: "Hello World: 15"'),
    ],
)
def test_talkers_and_listeners_run_until_ctrl_c(
    script: str, line: str, background: Callable[..., Background]
) -> None:
    # as ROS's talker and listener do: ten messages ended the talker before a listener started
    running = background(script)  # a router here, and the other end where a listener needs it
    assert running.wait_for(line, timeout=60), ''.join(running.output)
    running.process.send_signal(signal.SIGINT)
    code, output = running.finish()
    assert code == 0, output
    assert 'Traceback' not in output, output


@pytest.mark.parametrize('script', SCRIPTS)
def test_every_help_shows_the_defaults(script: str, tmp_path: Path) -> None:
    result = run(script, '--help', cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    text = ' '.join(result.stdout.split())
    assert '(default: None)' not in text
    assert not re.search(r'\(default[^)]*\) \(default', text), text  # said once
    # options that take a value, besides --connect (whose default is said in words)
    options = set(re.findall(r'(--[a-z-]+) [A-Z_]+ ', text)) - {'--connect'}
    if script in ARGS:
        assert '(default: 0)' in text and 'until Ctrl-C' in text
    elif options:
        assert '(default: ' in text, text


def test_service_server_and_client_in_two_processes(
    zros_router: Router, background: Callable[..., Background], tmp_path: Path
) -> None:
    endpoint = zros_router.endpoint
    server = background('add_two_ints_server.py', '--connect', endpoint, '--count', '4')
    assert server.wait_for('serving add_two_ints'), ''.join(server.output)
    client = run('add_two_ints_client.py', '--connect', endpoint, '20', '22', cwd=tmp_path)
    assert client.returncode == 0, client.stdout + client.stderr
    check_output(client.stdout, [r'20 \+ 22 = 42', r'and asynchronously: \[0, 2, 4\]'])
    code, output = server.finish()
    assert code == 0, output
    check_output(output, [r'Incoming request: a=20 b=22', r'answered 4 requests'])


def test_action_server_and_client_in_two_processes(
    zros_router: Router, background: Callable[..., Background], tmp_path: Path
) -> None:
    endpoint = zros_router.endpoint
    server = background('fibonacci_action_server.py', '--connect', endpoint, '--count', '2')
    assert server.wait_for('serving the fibonacci action'), ''.join(server.output)
    client = run('fibonacci_action_client.py', '--connect', endpoint, '--order', '6', cwd=tmp_path)
    assert client.returncode == 0, client.stdout + client.stderr
    check_output(
        client.stdout,
        [r'Result: \[0, 1, 1, 2, 3, 5, 8\] \(SUCCEEDED\)', r'The long goal ended CANCELED'],
    )
    code, output = server.finish()
    assert code == 0, output
    check_output(output, [r'Executing goal .*: order 6', r'canceled after', r'finished 2 goals'])


def test_the_tutorial_node_and_the_sensor_in_two_processes(
    zros_router: Router, background: Callable[..., Background], tmp_path: Path
) -> None:
    endpoint = zros_router.endpoint
    node = background('rosr_demo3_range.py', '--connect', endpoint, '--seconds', '5')
    assert node.wait_for('waiting for calibration pairs'), ''.join(node.output)
    sensor = run('sharp_sensor.py', '--connect', endpoint, cwd=tmp_path)
    assert sensor.returncode == 0, sensor.stdout + sensor.stderr
    check_output(sensor.stdout, [r'published 554 messages'])
    code, output = node.finish()
    assert code == 0, output
    check_output(output, [r'0\.8 V -> 0\.1[56]\d m', r'published 314 sensor_msgs/Range'])


def test_real_robot_lists_what_it_finds(
    zros_router: Router, zros_node: Callable[..., Node], tmp_path: Path
) -> None:
    robot = zros_node('robot')
    chatter = robot.create_publisher('std_msgs/msg/String', '/chatter')
    robot.create_timer(
        0.05, lambda: chatter.write(zros.Message('std_msgs/msg/String', data='from the robot'))
    )
    with spinning(robot):
        result = run(
            'real_robot.py', '--connect', zros_router.endpoint, '--topic', '/chatter', cwd=tmp_path
        )
    assert result.returncode == 0, result.stdout + result.stderr
    check_output(
        result.stdout,
        [
            r'no zenoh-bridge-ros2dds answered',
            r'/chatter \[std_msgs/msg/String\]',
            r"/chatter: .*data='from the robot'",
        ],
    )


def test_real_robot_explains_an_unreachable_bridge(tmp_path: Path) -> None:
    with Router() as router:
        endpoint = router.endpoint  # a free port, closed again below: nothing listens there
    result = run('real_robot.py', '--connect', endpoint, cwd=tmp_path)
    assert result.returncode == 0, result.stdout + result.stderr
    check_output(
        result.stdout, [f'No bridge answered at {endpoint}', r'nothing listens', r'robot_compose']
    )
