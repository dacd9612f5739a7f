"""Code that uses zros type-checks under mypy --strict (zros ships py.typed)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import zros

USER_CODE = """
import zros
from zros import cdr

def relay(node: zros.Node) -> zros.Publisher:
    pub = node.create_publisher('sensor_msgs/msg/Range', 'distance', qos='sensor_data')
    def on_voltage(message: cdr.Message) -> None:
        rng = zros.Message('sensor_msgs/msg/Range', min_range=0.04)
        rng.range = 0.2 / message.data
        rng.header.frame_id = 'sharp'
        pub.write(rng)
    node.create_subscription('std_msgs/msg/Float32', 'voltage', on_voltage)
    return pub

def decode_twist(data: bytes) -> float:
    twist = cdr.decode('geometry_msgs/msg/Twist', data)
    speed: float = twist.linear.x
    return speed

qos: zros.QoS = zros.QoS(5, zros.Reliability.BEST_EFFORT)

def serve(node: zros.Node) -> None:
    def add(request: cdr.Message) -> cdr.Message:
        return zros.Message('example_interfaces/srv/AddTwoInts_Response', sum=request.a + request.b)
    def add_rclpy(request: cdr.Message, response: cdr.Message) -> cdr.Message:
        response.sum = request.a + request.b
        return response
    async def add_async(request: cdr.Message) -> cdr.Message:
        return add(request)
    node.create_service('example_interfaces/srv/AddTwoInts', 'add', add)
    node.create_service('example_interfaces/srv/AddTwoInts', 'add_rclpy', add_rclpy)
    node.create_service('example_interfaces/srv/AddTwoInts', 'add_async', add_async)
    zros.Service('add_lambda', 'example_interfaces/srv/AddTwoInts', lambda request: request, node=node)

def gain(node: zros.Node) -> float:
    value = node.get_parameter('gain')
    return float(value) if isinstance(value, (int, float)) else 1.0
"""


#: message classes are made at run time: a program declares, for the type checker, the fields
#: it reads (under TYPE_CHECKING), and publishers and subscribers carry that class through.
#: ``# mypy:`` ends each line mypy reports on, with the start of what it says there.
TYPED_CODE = """
from typing import TYPE_CHECKING
import zros
from zros import cdr

if TYPE_CHECKING:
    class String(cdr.Message):
        data: str
    class Int32(cdr.Message):
        data: int
else:
    String = cdr.get_class('std_msgs/msg/String')
    Int32 = cdr.get_class('std_msgs/msg/Int32')

def chatter(node: zros.Node) -> None:
    pub = node.create_publisher(String, '/chatter', 10)
    reveal_type(pub)  # mypy: zros.pubsub.publisher.Publisher[user_program.String]
    pub.write(String(data='hello'))
    reveal_type(zros.Message(String, data='hello'))  # mypy: user_program.String
    reveal_type(zros.Message('std_msgs/msg/String'))  # mypy: zros.cdr.message.Message
    # a field of an untyped message is Any on purpose (as rclpy's): declare the class to check it
    reveal_type(zros.Message('std_msgs/msg/String').data)  # mypy: Any
    def on_message(msg: String) -> None:
        reveal_type(msg.data)  # mypy: str
    sub = node.create_subscription(String, '/chatter', on_message)
    reveal_type(sub)  # mypy: zros.pubsub.subscriber.Subscriber[user_program.String]
    reveal_type(sub.read_message())  # mypy: user_program.String | None
    reveal_type(sub.take())  # mypy: list[user_program.String]
    reveal_type(sub.wait_for_message(1.0))  # mypy: user_program.String | None
    reveal_type(zros.Subscriber('/chatter', String))  # mypy: zros.pubsub.subscriber.Subscriber[user_program.String]
    reveal_type(zros.Subscriber('/chatter', String, raw=True).take())  # mypy: list[bytes]
    untyped = node.create_subscription('std_msgs/msg/String', '/chatter')
    reveal_type(untyped)  # mypy: zros.pubsub.subscriber.Subscriber[zros.cdr.message.Message]
    reveal_type(zros.Publisher('/chatter', 'std_msgs/msg/String'))  # mypy: zros.pubsub.publisher.Publisher[zros.cdr.message.Message]
    pub.write(Int32(data=1))  # mypy: Argument 1 to "write" of "Publisher" has incompatible type "Int32"; expected "String"
    def on_number(msg: Int32) -> None:
        pass
    node.create_subscription(String, '/chatter', on_number)  # mypy: Argument 3 to "create_subscription"
    count: int = sub.take()[0].data  # mypy: Incompatible types in assignment (expression has type "str"
    bare: zros.Subscriber = untyped
    zros.QoS().with_(deph=1)  # mypy: Unexpected keyword argument "deph"

async def stream(sub: zros.Subscriber[String]) -> None:
    async for msg in sub:
        reveal_type(msg)  # mypy: user_program.String
"""


def _mypy(tmp_path: Path, code: str) -> subprocess.CompletedProcess[str]:
    """mypy --strict on ``code`` as the module ``user_program``."""
    if shutil.which('mypy', path=str(Path(sys.executable).parent)) is None:
        pytest.skip('mypy is not installed in this environment')
    program = tmp_path / 'user_program.py'
    program.write_text(code)
    # mypy does not follow the import hooks of editable installs: point it at the package
    package_root = Path(zros.__file__).resolve().parent.parent
    return subprocess.run(
        [sys.executable, '-m', 'mypy', '--strict', '--no-incremental', str(program)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        # without PYTHONPATH: mypy then checks zros as the user's own code, errors inside too
        env={
            **{k: v for k, v in os.environ.items() if k != 'PYTHONPATH'},
            'MYPYPATH': str(package_root),
        },
        check=False,
    )


def test_user_code_passes_mypy_strict(tmp_path: Path) -> None:
    result = _mypy(tmp_path, USER_CODE)
    assert result.returncode == 0, result.stdout + result.stderr


def test_publishers_and_subscribers_carry_their_message_class(tmp_path: Path) -> None:
    result = _mypy(tmp_path, TYPED_CODE)
    report = result.stdout + result.stderr
    expected = {
        number: line.split('  # mypy: ')[1]
        for number, line in enumerate(TYPED_CODE.splitlines(), 1)
        if '  # mypy: ' in line
    }
    said: dict[int, str] = {}
    for line in result.stdout.splitlines():
        if line.startswith('user_program.py:'):
            _, number, text = line.split(':', 2)
            message = text.split(': ', 1)[1].removeprefix('Revealed type is "')
            said.setdefault(int(number), message)  # the first: an error, before its notes
    assert said.keys() == expected.keys(), report
    for number, text in expected.items():
        assert said[number].startswith(text), (number, text, report)


def test_the_typed_program_runs_with_the_generated_classes() -> None:
    namespace: dict[str, object] = {'__name__': 'user_program'}
    exec(compile(TYPED_CODE, 'user_program.py', 'exec'), namespace)
    string = namespace['String']
    assert isinstance(string, type)
    assert issubclass(string, zros.cdr.Message)
    assert string(data='hi').data == 'hi'
    assert string.__msgtype__ == 'std_msgs/msg/String'
