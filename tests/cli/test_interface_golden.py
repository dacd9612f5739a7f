"""``zros interface show`` prints what ``ros2 interface show`` prints, byte for byte.

The reference comes from ``ros2_interface_show.py``: ros2interface's algorithm on rosidl_adapter's
parser over the interface files of the ROS 2 Jazzy wheels (the interop extra), made as the tests
run. zros is compared in two set-ups: definitions from the rosbags typestore (the
default; the text with comments then comes from the wheels' files), and definitions read from
those files as from a sourced ROS install (``AMENT_PREFIX_PATH``).
"""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Iterator
from dataclasses import replace

import pytest

from tests.cli.conftest import ZROS
from tests.cli.ros2_interface_show import INTERFACE_CASES, MODES, available, reference_text
from zros.cdr.expand import expanded_text
from zros.cdr.parser import parse_message
from zros.cdr.registry import TypeRegistry, default_registry, set_default_registry
from zros.cli.main import main

FLAGS = {'': [], '.no-comments': ['--no-comments'], '.all-comments': ['--all-comments']}


@pytest.fixture(params=['typestore', 'ament'])
def registry(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    """The default registry of the CLI: plain, or with the wheels as an ament prefix."""
    if not available():
        pytest.skip('the reference texts need the ROS 2 wheels of the interop extra')
    monkeypatch.delenv('ZROS_INTERFACE_PATH', raising=False)
    if request.param == 'ament':
        monkeypatch.setenv('AMENT_PREFIX_PATH', sys.prefix)
    else:
        monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)
    previous = default_registry()
    set_default_registry(TypeRegistry())
    yield str(request.param)
    set_default_registry(previous)


@pytest.mark.parametrize('mode', list(MODES))
@pytest.mark.parametrize('type_name', list(INTERFACE_CASES))
def test_show_matches_ros2(
    registry: str, type_name: str, mode: str, capsys: pytest.CaptureFixture[str]
) -> None:
    if registry == 'typestore' and default_registry().find(type_name) is None:
        pytest.skip(f'{type_name} is not in the rosbags typestore')
    assert main(['interface', 'show', type_name, *FLAGS[mode]]) == 0
    assert capsys.readouterr().out == reference_text(type_name, mode)


def test_the_console_script_reads_the_type_from_stdin() -> None:
    if ZROS is None or not available():
        pytest.skip('needs the console script and the ROS 2 wheels')
    result = subprocess.run(
        [ZROS, 'interface', 'show', '-'],
        input='geometry_msgs/msg/PoseStamped\n',
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout == reference_text('geometry_msgs/msg/PoseStamped', '')
    empty = subprocess.run(
        [ZROS, 'interface', 'show', '-'], input='', capture_output=True, text=True, check=False
    )
    assert empty.returncode == 2
    assert 'expected a type name on standard input' in empty.stderr


def test_without_any_text_the_definition_is_expanded_without_comments() -> None:
    # definitions with no text anywhere (as a typestore gives them): rendered, then expanded
    registry = TypeRegistry('jazzy', paths=[], ament=False)
    for name, text in (
        ('my_msgs/msg/Inner', 'int32 X=1  # a constant\nfloat64 x 1.5\n'),
        ('my_msgs/msg/Outer', '# about Outer\nInner[2] inners  # two\nstring name\n'),
    ):
        registry.register(replace(parse_message(name, text), source=''))
    assert expanded_text(registry, 'my_msgs/msg/Outer', 'all') == (
        'Inner[2] inners\n\tint32 X=1\n\tfloat64 x 1.5\nstring name\n'
    )
    # a type registered from text, as a bag's are: its own text, comments included
    registry.register_text('my_msgs/msg/Pair', '# a pair\nfloat32 a  # first\nInner i\n')
    assert expanded_text(registry, 'my_msgs/msg/Pair') == (
        '# a pair\nfloat32 a  # first\nInner i\n\tint32 X=1\n\tfloat64 x 1.5\n'
    )
    assert expanded_text(registry, 'my_msgs/msg/Pair', 'none') == (
        'float32 a  #\nInner i\n\tint32 X=1\n\tfloat64 x 1.5\n'
    )
