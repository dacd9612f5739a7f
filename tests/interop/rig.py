"""The interop rig: real ROS 2 (rclpy) behind a bridge, zros in the test process.

Local mode (default): a private network namespace whose only interface is ``lo`` holds the
bridge stand-in and the rclpy workers, so DDS discovery and data never leave it (Fast DDS is
also restricted to UDPv4, so nothing goes through /dev/shm either). The stand-in's Zenoh side
listens on a unix socket in a temporary folder: unix sockets live in the file system, not in a
network namespace, so zros in the test process (outside the namespace) connects to it with no
network interface at all.

External mode (``ZROS_INTEROP_BRIDGE=tcp/bridge:7447``, see ``docker/``): zros connects to that
endpoint (a real zenoh-bridge-ros2dds); rclpy workers are reached through
``ZROS_INTEROP_ROS_WORKER=tcp:HOST:PORT`` or ``unix:PATH`` (``ros_worker.py --serve``), and the
bridge's namespace is ``ZROS_INTEROP_BRIDGE_NAMESPACE`` (default ``/``).
"""

from __future__ import annotations

import contextlib
import json
import os
import selectors
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
WORKER_SCRIPT = Path(__file__).with_name('ros_worker.py')

ENV_BRIDGE = 'ZROS_INTEROP_BRIDGE'
ENV_BRIDGE_NAMESPACE = 'ZROS_INTEROP_BRIDGE_NAMESPACE'
ENV_WORKER = 'ZROS_INTEROP_ROS_WORKER'

#: how long a rig waits for a process to come up
START_TIMEOUT = 30.0
#: how long a test waits for the ROS side (discovery, matching, a message, a reply) before it
#: fails: generous, because a green run never waits it out and a loaded machine (two busy
#: cores, DDS discovery in another process) can take seconds where an idle one takes ms
DEADLINE = 60.0


class RigError(RuntimeError):
    """A process of the rig failed or did not answer in time."""


def external_bridge() -> str | None:
    """The endpoint of a real bridge to test against, if the environment names one."""
    return os.environ.get(ENV_BRIDGE) or None


def local_skip_reason() -> str | None:
    """Why the local (network namespace) rig cannot run here, or None."""
    if sys.platform != 'linux':
        return 'the interop rig needs Linux network namespaces'
    if os.geteuid() != 0:
        return 'the interop rig creates a network namespace: run as root'
    if shutil.which('ip') is None:
        return 'the interop rig needs the "ip" command (iproute2)'
    try:
        import rclpy  # noqa: F401
    except ImportError:
        return 'rclpy (ROS 2 Jazzy from PyPI, the "interop" extra) is not importable'
    return None


# --- a line channel with timeouts ---------------------------------------------------------------


class LineChannel:
    """JSON lines over two file descriptors (pipes or one socket), with read timeouts."""

    def __init__(self, read_fd: int, write_fd: int) -> None:
        self._read_fd = read_fd
        self._write_fd = write_fd
        self._buffer = b''
        self._selector = selectors.DefaultSelector()
        self._selector.register(read_fd, selectors.EVENT_READ)

    def send(self, obj: dict[str, Any]) -> None:
        data = (json.dumps(obj) + '\n').encode()
        while data:
            data = data[os.write(self._write_fd, data) :]

    def receive(self, timeout: float) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while b'\n' not in self._buffer:
            remaining = deadline - time.monotonic()
            if remaining <= 0 or not self._selector.select(remaining):
                raise RigError(f'no answer within {timeout:.0f} s')
            chunk = os.read(self._read_fd, 1 << 20)
            if not chunk:
                raise RigError('the other side closed the channel')
            self._buffer += chunk
        line, _, self._buffer = self._buffer.partition(b'\n')
        return json.loads(line)  # type: ignore[no-any-return]

    def close(self) -> None:
        self._selector.close()


def qos_spec(
    depth: int = 10,
    reliability: str = 'reliable',
    durability: str = 'volatile',
    history: str = 'keep_last',
) -> dict[str, Any]:
    """The ``qos`` argument of the worker commands."""
    return {
        'depth': depth,
        'reliability': reliability,
        'durability': durability,
        'history': history,
    }


class RosWorker:
    """Client of one ``ros_worker.py`` (an rclpy node): see that script for the commands."""

    def __init__(self, channel: LineChannel, closer: Callable[[], None], what: str) -> None:
        self._channel = channel
        self._closer = closer
        self.what = what
        self._count = 0
        hello = channel.receive(START_TIMEOUT)
        self.node_name = hello.get('ready', '')

    def call(self, cmd: str, timeout: float = DEADLINE, **args: Any) -> dict[str, Any]:
        self._channel.send({'cmd': cmd, 'timeout': timeout, **args})
        reply = self._channel.receive(timeout + 20.0)
        if not reply.get('ok'):
            raise RigError(f'{self.what}: {cmd} failed: {reply.get("error")}')
        return reply

    def _name(self, prefix: str) -> str:
        self._count += 1
        return f'{prefix}{self._count}'

    def publisher(self, topic: str, type_name: str, qos: dict[str, Any] | None = None) -> str:
        name = self._name('pub')
        self.call('publisher', name=name, topic=topic, type=type_name, qos=qos or qos_spec())
        return name

    def subscription(self, topic: str, type_name: str, qos: dict[str, Any] | None = None) -> str:
        name = self._name('sub')
        self.call('subscription', name=name, topic=topic, type=type_name, qos=qos or qos_spec())
        return name

    def publish(self, name: str, messages: list[bytes], interval: float = 0.0) -> None:
        self.call('publish', name=name, data=[m.hex() for m in messages], interval=interval)

    def wait_subscribers(self, name: str, count: int = 1, timeout: float = DEADLINE) -> int:
        return int(self.call('wait_subscribers', timeout, name=name, count=count)['count'])

    def wait_publishers(self, name: str, count: int = 1, timeout: float = DEADLINE) -> int:
        """Wait until the subscription ``name`` is matched with ``count`` DDS writers (a bridge's
        route to it): messages published before that are lost to a volatile reader."""
        return int(self.call('wait_publishers', timeout, name=name, count=count)['count'])

    def wait_messages(self, name: str, count: int = 1, timeout: float = DEADLINE) -> list[bytes]:
        reply = self.call('wait_messages', timeout, name=name, count=count)
        return [bytes.fromhex(item) for item in reply['messages']]

    def wait_readers(self, topic: str, count: int = 1, timeout: float = DEADLINE) -> int:
        """Wait until the ROS graph shows ``count`` DDS readers of ``topic`` (hidden ones too,
        say an action's ``_action/feedback``); returns how many it shows."""
        return int(self.call('wait_readers', timeout, topic=topic, count=count)['count'])

    def topics(self) -> dict[str, list[str]]:
        return {name: types for name, types in self.call('topics')['topics']}

    def wait_topic(
        self, topic: str, type_name: str, present: bool = True, timeout: float = DEADLINE
    ) -> dict[str, list[str]]:
        reply = self.call('wait_topic', timeout, topic=topic, type=type_name, present=present)
        return {name: types for name, types in reply['topics']}

    def service(self, service: str, type_name: str) -> str:
        """An echo server: each response copies the request's fields of the same name."""
        name = self._name('srv')
        self.call('service', name=name, service=service, type=type_name)
        return name

    def call_service(
        self, service: str, type_name: str, request: bytes, timeout: float = DEADLINE
    ) -> bytes:
        reply = self.call('call', timeout, service=service, type=type_name, data=request.hex())
        return bytes.fromhex(reply['response'])

    def action_server(
        self,
        action: str,
        *,
        cancelable: bool = False,
        abort_order: int | None = None,
        hold: float = 0.0,
    ) -> str:
        """A ``test_msgs/action/Fibonacci`` server publishing feedback at every step; it accepts
        cancel requests if ``cancelable``, aborts goals of ``abort_order`` after their first
        step, and holds a goal after its first step until canceled (at most ``hold`` s)."""
        name = self._name('action')
        self.call(
            'action_server',
            name=name,
            action=action,
            cancelable=cancelable,
            abort_order=abort_order,
            hold=hold,
        )
        return name

    def action_call(
        self,
        action: str,
        order: int,
        timeout: float = DEADLINE,
        *,
        cancel_after_feedback: bool = False,
        record: bool = False,
        feedback_count: int = 0,
    ) -> dict[str, Any]:
        """Send a Fibonacci goal; ``goal_id``, ``status``, ``sequence`` and ``feedback`` of its
        run, with ``cancel`` (the cancel response) and what the action's topics carried
        (``topic_feedback``, ``statuses``) when asked for (see ``ros_worker.py``)."""
        return self.call(
            'action_call',
            timeout,
            action=action,
            order=order,
            cancel_after_feedback=cancel_after_feedback,
            record=record,
            feedback_count=feedback_count,
        )

    # parameters: values, parameters and descriptors as JSON, see ros_worker.py

    def param_node(
        self,
        node: str,
        parameters: list[dict[str, Any]],
        *,
        namespace: str = '/',
        allow_undeclared: bool = False,
    ) -> tuple[str, str]:
        """A further rclpy node declaring ``parameters``; its handle and fully qualified name."""
        name = self._name('pnode')
        reply = self.call(
            'param_node',
            name=name,
            node=node,
            namespace=namespace,
            parameters=parameters,
            allow_undeclared=allow_undeclared,
        )
        return name, str(reply['fqn'])

    def param_node_op(
        self, name: str, op: str, parameters: list[dict[str, Any]]
    ) -> list[dict[str, Any]]:
        """``declare``, ``undeclare`` or ``set`` ``parameters`` on a ``param_node`` itself; the
        results of a ``set``."""
        return list(
            self.call('param_node_op', name=name, op=op, parameters=parameters).get('results', [])
        )

    def param_client(self, node: str, timeout: float = DEADLINE) -> tuple[str, bool]:
        """An rclpy ``AsyncParameterClient`` of ``node``; its handle and whether all six
        services became ready within ``timeout``."""
        name = self._name('pclient')
        reply = self.call('param_client', timeout, name=name, node=node)
        return name, bool(reply['ready'])

    def param_call(
        self, name: str, op: str, timeout: float = DEADLINE, **args: Any
    ) -> dict[str, Any]:
        """One call of a parameter client (``list``, ``get``, ``types``, ``describe``, ``set``,
        ``set_atomically``, ``delete``)."""
        reply = self.call('param_call', timeout, name=name, op=op, **args)
        reply.pop('ok', None)
        return reply

    def param_events(self, client: str) -> str:
        """Record ``/parameter_events`` through ``client.on_parameter_event``."""
        name = self._name('pevents')
        self.call('param_events', name=name, client=client)
        return name

    def wait_param_events(
        self, name: str, node: str, count: int = 1, timeout: float = DEADLINE
    ) -> list[dict[str, Any]]:
        """The recorded events of ``node`` (once there are ``count``, or after ``timeout``)."""
        reply = self.call('wait_param_events', timeout, name=name, node=node, count=count)
        return list(reply['events'])

    def destroy(self, name: str) -> None:
        self.call('destroy', name=name)

    def close(self) -> None:
        with contextlib.suppress(OSError):
            self._channel.send({'cmd': 'exit'})
        self._channel.close()
        self._closer()


def connect_worker(address: str) -> RosWorker:
    """A worker behind ``ros_worker.py --serve`` at ``tcp:HOST:PORT`` or ``unix:PATH``."""
    scheme, _, where = address.partition(':')
    if scheme == 'unix':
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.connect(where)
    elif scheme == 'tcp':
        host, _, port = where.rpartition(':')
        sock = socket.create_connection((host, int(port)), timeout=START_TIMEOUT)
        sock.settimeout(None)
    else:
        raise ValueError(f'{ENV_WORKER} must be tcp:HOST:PORT or unix:PATH, not {address!r}')
    return RosWorker(LineChannel(sock.fileno(), sock.fileno()), sock.close, f'worker {address}')


# --- processes in a network namespace -----------------------------------------------------------


def _stop(process: subprocess.Popen[bytes], grace: float = 5.0) -> None:
    """Stop one process we started, by its PID: SIGTERM, then SIGKILL after ``grace``."""
    if process.poll() is not None:
        return
    with contextlib.suppress(ProcessLookupError):
        os.kill(process.pid, signal.SIGTERM)
    try:
        process.wait(grace)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.kill(process.pid, signal.SIGKILL)
        process.wait(grace)


@dataclass
class NetNamespace:
    """A network namespace with only ``lo`` up, deleted by name on close."""

    name: str
    processes: list[subprocess.Popen[bytes]] = field(default_factory=list)

    @classmethod
    def create(cls, name: str) -> NetNamespace:
        subprocess.run(['ip', 'netns', 'add', name], check=True, capture_output=True)
        namespace = cls(name)
        try:
            subprocess.run(
                ['ip', '-n', name, 'link', 'set', 'lo', 'up'], check=True, capture_output=True
            )
        except BaseException:
            namespace.close()
            raise
        return namespace

    def interfaces(self) -> list[str]:
        output = subprocess.run(
            ['ip', '-n', self.name, '-o', 'link', 'show'],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        return [line.split(':')[1].strip().split('@')[0] for line in output.splitlines()]

    def spawn(self, args: list[str], env: dict[str, str], stderr: Any) -> subprocess.Popen[bytes]:
        """Start ``args`` inside the namespace (``ip netns exec`` execs it: the PID is its own)."""
        process = subprocess.Popen(
            ['ip', 'netns', 'exec', self.name, *args],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=stderr,
            env=env,
            cwd=REPO,
        )
        self.processes.append(process)
        return process

    def close(self) -> None:
        for process in reversed(self.processes):
            _stop(process)
        self.processes.clear()
        subprocess.run(['ip', 'netns', 'delete', self.name], check=False, capture_output=True)


_rig_count = 0


class LocalRig:
    """A namespace, the stand-in listening on a unix socket, and rclpy workers on demand."""

    def __init__(self, bridge_namespace: str = '/', version: str = '1.10.0') -> None:
        global _rig_count  # noqa: PLW0603
        _rig_count += 1
        self.bridge_namespace = bridge_namespace
        self.version = version
        self.domain = 40 + _rig_count % 50
        self.tmp = Path(tempfile.mkdtemp(prefix='zros_interop_'))
        self.endpoint = f'unixsock-stream/{self.tmp / "bridge.sock"}'
        self.standin_log = self.tmp / 'standin.log'
        self.env = {
            **os.environ,
            'PYTHONPATH': str(REPO),
            'PYTHONUNBUFFERED': '1',
            'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp',
            'ROS_DOMAIN_ID': str(self.domain),
            # Fast DDS over UDP on the namespace's lo only: its default shared-memory transport
            # would go through /dev/shm, which network namespaces do not separate
            'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4',
            'ROS_LOG_DIR': str(self.tmp / 'roslog'),
        }
        for name in ('ZENOH_CONFIG', 'ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS'):
            self.env.pop(name, None)
        self.netns = NetNamespace.create(f'zros_interop_{os.getpid()}_{_rig_count}')
        self.workers: list[RosWorker] = []
        try:
            self.zid = self._start_standin()
        except BaseException:
            self.close()
            raise

    def _start_standin(self) -> str:
        log = self.standin_log.open('wb')
        args = [sys.executable, '-m', 'tests.interop.bridge_standin', '--listen', self.endpoint]
        args += ['--namespace', self.bridge_namespace, '--version', self.version]
        process = self.netns.spawn(args, self.env, log)
        log.close()
        assert process.stdout is not None
        selector = selectors.DefaultSelector()
        selector.register(process.stdout, selectors.EVENT_READ)
        if not selector.select(START_TIMEOUT):
            raise RigError(f'the stand-in did not start; log:\n{self.log_tail()}')
        line = process.stdout.readline().decode().split()
        selector.close()
        if len(line) != 2 or line[0] != 'READY':
            raise RigError(f'the stand-in failed to start; log:\n{self.log_tail()}')
        self.standin = process
        return line[1]

    def log_tail(self, lines: int = 40) -> str:
        try:
            return '\n'.join(self.standin_log.read_text(errors='replace').splitlines()[-lines:])
        except OSError:
            return '(no log)'

    def standin_alive(self) -> bool:
        return self.standin.poll() is None

    def new_worker(self) -> RosWorker:
        log = (self.tmp / f'worker{len(self.workers)}.log').open('wb')
        process = self.netns.spawn([sys.executable, str(WORKER_SCRIPT)], self.env, log)
        log.close()
        assert process.stdin is not None and process.stdout is not None
        channel = LineChannel(process.stdout.fileno(), process.stdin.fileno())

        def closer() -> None:
            try:
                process.wait(5)
            except subprocess.TimeoutExpired:
                _stop(process)
            for stream in (process.stdin, process.stdout):
                if stream is not None:
                    stream.close()

        worker = RosWorker(channel, closer, f'worker pid {process.pid}')
        self.workers.append(worker)
        return worker

    def close(self) -> None:
        for worker in self.workers:
            with contextlib.suppress(Exception):
                worker.close()
        self.workers.clear()
        self.netns.close()
        shutil.rmtree(self.tmp, ignore_errors=True)


@dataclass
class BridgeUnderTest:
    """What the tests see: where zros connects, the bridge's namespace, and a worker factory."""

    endpoint: str
    namespace: str
    external: bool
    new_worker: Callable[[], RosWorker]
    rig: LocalRig | None = None


@contextlib.contextmanager
def bridge_under_test(namespace: str = '/') -> Iterator[BridgeUnderTest]:
    """The real bridge of the environment (external mode) or a local rig with a stand-in."""
    endpoint = external_bridge()
    if endpoint is not None:
        address = os.environ.get(ENV_WORKER)

        def new_worker() -> RosWorker:
            if not address:
                raise RigError(f'external mode needs {ENV_WORKER} to reach rclpy workers')
            return connect_worker(address)

        yield BridgeUnderTest(endpoint, os.environ.get(ENV_BRIDGE_NAMESPACE, '/'), True, new_worker)
        return
    rig = LocalRig(namespace)
    try:
        yield BridgeUnderTest(rig.endpoint, namespace, False, rig.new_worker, rig)
    finally:
        rig.close()
