"""The first Ctrl-C ends every blocking call of the public API within half a second.

Each case runs in a process of its own: the child enters the call, says so, the test sends
SIGINT and times the child's report of how the call ended. The rule: a call that reports a
timeout by its return value returns it (None, False, 0); one that raises on timeout raises
KeyboardInterrupt.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.processes import Script
from zros.transport import Router

#: how soon the child must report after SIGINT
REACTION = 0.5

CHILD = """
import sys, threading, time
import zros

node = zros.init('interrupted')
{setup}

def call():
    return {call}

def announce(line):
    # say 'inside' once the main thread is in the call, below the module's frame
    main = threading.main_thread().ident
    while True:
        frame = sys._current_frames().get(main)
        depth, outer = 0, frame
        while outer is not None and outer.f_back is not None:
            depth, outer = depth + 1, outer.f_back
        if outer is not None and outer.f_lineno == line and depth >= 2:
            print('inside', flush=True)
            return
        time.sleep(0.001)

threading.Thread(target=announce, args=(sys._getframe().f_lineno + 2,), daemon=True).start()
try:
    outcome = repr(call())
except KeyboardInterrupt:
    outcome = 'KeyboardInterrupt'
print('outcome', outcome, flush=True)
for name in ('recorder', 'player'):  # what a with block would close
    if name in globals():
        globals()[name].close()
zros.shutdown()
print('closed', flush=True)
"""

STUCK_SERVER = """
server = zros.Node('server')  # never spun: requests wait for ever
server.create_service('std_srvs/srv/Trigger', 'stuck', lambda request, response: response)
client = node.create_client('std_srvs/srv/Trigger', 'stuck')
assert client.wait_for_service(60)
"""

ACTIONS = """
release = threading.Event()

def execute(goal):
    release.wait()  # a goal that runs for ever

server = zros.Node('server')  # never spun: goal callbacks wait for ever
server.create_action_server('example_interfaces/action/Fibonacci', 'slow', execute)
server.create_action_server('example_interfaces/action/Fibonacci', 'deciding', execute,
                            goal_callback=lambda goal: True)
slow = node.create_action_client('example_interfaces/action/Fibonacci', 'slow')
deciding = node.create_action_client('example_interfaces/action/Fibonacci', 'deciding')
assert slow.wait_for_server(60) and deciding.wait_for_server(60)
handle = slow.send_goal(order=3, timeout=60)
"""

BAG = """
from zros.bag.write.bag_writer import BagTopic, BagWriter
writer = BagWriter({path!r})
writer.add_topic(BagTopic.from_registry(node.registry, '/chatter', 'std_msgs/msg/String', []))
data = zros.cdr.encode(zros.Message('std_msgs/msg/String', data='hi'))
writer.write(0, 0, data, 0)
writer.write(0, 3600 * 10**9, data, 3600 * 10**9)  # an hour later
writer.close()
from zros.bag import Player
player = Player(node, {path!r})
"""

#: name -> (setup, call, outcome printed)
CASES: dict[str, tuple[str, str, str]] = {
    'wait_for_message': (
        "sub = zros.Subscriber('silence', 'std_msgs/msg/String')",
        'sub.wait_for_message()',
        'None',
    ),
    'wait_for_message on a thread': (
        "sub = zros.Subscriber('silence', 'std_msgs/msg/String')\n"
        'got = []\n'
        'worker = threading.Thread(target=lambda: got.append(sub.wait_for_message()))\n'
        'worker.start()',
        '(zros.spin(), worker.join(5), got)[2]',
        '[None]',
    ),
    'wait_for_subscribers': (
        "pub = zros.Publisher('lonely', 'std_msgs/msg/String')",
        'pub.wait_for_subscribers(timeout=None)',
        'False',
    ),
    'node.wait_for_publishers': ('', "node.wait_for_publishers('/nobody', timeout=None)", 'False'),
    'node.wait_for_subscribers': (
        '',
        "node.wait_for_subscribers('/nobody', timeout=None)",
        'False',
    ),
    'graph.wait_until': ('', 'node.graph.wait_until(lambda: False)', 'False'),
    'wait_for_service': (
        "client = node.create_client('std_srvs/srv/Trigger', 'nothing')",
        'client.wait_for_service(timeout=None)',
        'False',
    ),
    'wait_for_request': (
        "service = node.create_service('std_srvs/srv/Trigger', 'polled')",
        'service.wait_for_request()',
        'None',
    ),
    'spin': ('', 'zros.spin()', 'None'),
    'spin_once(None)': ('', 'zros.spin_once(None)', '0'),
    'Rate.sleep': ('rate = node.create_rate(0.001)', 'rate.sleep()', 'None'),
    'Rate.sleep without a node': ('rate = zros.Rate(0.001)', 'rate.sleep()', 'None'),
    'sim clock sleep_until': (
        "sim = zros.Node('sim', use_sim_time=True)",
        'sim.clock.sleep_until(zros.Time(10**18))',
        'False',
    ),
    'service call': (STUCK_SERVER, 'client.call(timeout=3600)', 'KeyboardInterrupt'),
    'service call on a thread': (
        STUCK_SERVER + 'got = []\n'
        'def work():\n'
        '    try:\n'
        '        got.append(client.call(timeout=3600))\n'
        '    except KeyboardInterrupt:\n'
        "        got.append('KeyboardInterrupt')\n"
        'worker = threading.Thread(target=work)\n'
        'worker.start()',
        '(zros.spin(), worker.join(5), got)[2]',
        "['KeyboardInterrupt']",
    ),
    'call_async result': (
        STUCK_SERVER,
        'client.call_async(timeout=3600).result()',
        'KeyboardInterrupt',
    ),
    'await call_async': (
        STUCK_SERVER + 'import asyncio\n'
        'async def wait():\n'
        '    return await client.call_async(timeout=3600)\n',
        'asyncio.run(wait())',
        'KeyboardInterrupt',
    ),
    'async for': (
        "import asyncio\nsub = zros.Subscriber('silence', 'std_msgs/msg/String')\n"
        'async def first():\n'
        '    async for message in sub:\n'
        '        return message\n',
        'asyncio.run(first())',
        'None',
    ),
    'action send_goal': (ACTIONS, 'deciding.send_goal(order=3, timeout=3600)', 'KeyboardInterrupt'),
    'action result': (ACTIONS, 'handle.result()', 'KeyboardInterrupt'),
    'action result_async': (ACTIONS, 'handle.result_async().result()', 'KeyboardInterrupt'),
    'action wait_for_status': (
        ACTIONS,
        'handle.wait_for_status(lambda status: status.terminal)',
        'False',
    ),
    'action wait_for_server': (
        "lonely = node.create_action_client('example_interfaces/action/Fibonacci', 'none')",
        'lonely.wait_for_server(timeout=None)',
        'False',
    ),
    'bag play': (BAG, 'player.play()', 'None'),
    'bag play in the background': (BAG, '(player.start(), player.wait())[1]', 'True'),
    'recorder wait_for_topics': (
        "from zros.bag import Recorder\nrecorder = Recorder(node, {path!r}, ['/nothing'])",
        "recorder.wait_for_topics(['/nothing'], timeout=None)",
        'False',
    ),
}


@pytest.fixture
def children(zros_router: Router) -> Iterator[list[Script]]:
    started: list[Script] = []
    try:
        yield started
    finally:
        for child in started:
            child.stop()


@pytest.mark.parametrize('case', list(CASES))
def test_the_first_ctrl_c_ends_the_call(
    case: str, zros_router: Router, children: list[Script], tmp_path: Path
) -> None:
    setup, call, expected = CASES[case]
    setup = setup.format(path=str(tmp_path / 'bag'))
    child = Script(CHILD.format(setup=setup, call=call), zros_router)
    children.append(child)
    child.expect('inside', 120)  # process start and setup: generous on a loaded machine
    sent = time.monotonic()
    child.process.send_signal(signal.SIGINT)
    arrived, line = child.expect('outcome', 30)
    reaction = arrived - sent
    print(f'{case}: {line} after {reaction * 1000:.0f} ms')
    assert line == f'outcome {expected}'
    assert reaction < REACTION
    child.expect('closed', 30)
    assert child.process.wait(30) == 0, child.stop()


#: a wait on the main thread while SIGINT lands on another thread: Python's handler is then
#: only pending, and the main thread must come back to run it (a blocked acquire is cut short
#: only by a signal that lands on the main thread while it is blocked)
ELSEWHERE = """
import linecache, signal, sys, threading, time
from zros.runtime import signal as zros_signal

signal.signal(signal.SIGINT, lambda signum, frame: zros_signal.interrupt())
main = threading.main_thread().ident
waiting = zros_signal.Signal()
sent = []

def blocked():
    # the main thread sits on a lock acquire inside zros's signal module (were it still running
    # Python, the pending handler would run)
    frame = sys._current_frames()[main]
    line = linecache.getline(frame.f_code.co_filename, frame.f_lineno)
    return frame.f_code.co_filename == zros_signal.__file__ and '.acquire(' in line

def ctrl_c_elsewhere():
    while not (waiting and blocked()):
        time.sleep(0.001)
    sent.append(time.monotonic())
    signal.pthread_kill(threading.get_ident(), signal.SIGINT)  # to this thread, not the main one

threading.Thread(target=ctrl_c_elsewhere, daemon=True).start()
ended = waiting.wait_for(lambda: False, 30)
print(ended, zros_signal.interrupted(), f'{time.monotonic() - sent[0]:.3f}', flush=True)
"""


def test_a_ctrl_c_that_lands_on_another_thread_ends_a_wait_on_the_main_thread() -> None:
    result = subprocess.run(
        [sys.executable, '-c', ELSEWHERE], capture_output=True, text=True, timeout=120, check=False
    )
    assert result.returncode == 0, result.stderr
    ended, interrupted, reaction = result.stdout.split()
    assert (ended, interrupted) == ('False', 'True')
    assert float(reaction) < REACTION
