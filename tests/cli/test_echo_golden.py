"""``zros topic echo`` prints what ``ros2 topic echo`` prints for the same messages.

The files in ``golden/`` were written by rosidl_runtime_py's ``message_to_yaml`` and
``message_to_csv`` (the functions behind ``ros2 topic echo``) from rclpy messages decoded from
the CDR of the cases in ``echo_cases.py``; see ``golden/SOURCES.md``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.cli.conftest import Cli
from tests.cli.echo_cases import CASES, CSV_CASES
from zros.cdr import decode, default_registry, encode
from zros.cdr.registry import TypeRegistry
from zros.cli.message_text import message_to_csv, message_to_yaml, to_yaml

GOLDEN = Path(__file__).parent / 'golden'
#: the ROS wheels of the interop extra install test_msgs' definitions here
SHARE = Path(sys.prefix) / 'share'


def registry_for(type_name: str) -> Any:
    if not type_name.startswith('test_msgs/'):
        return default_registry()
    if not (SHARE / 'test_msgs').is_dir():
        pytest.skip('test_msgs definitions come with the interop extra (ROS 2 wheels)')
    return TypeRegistry('jazzy', paths=[SHARE], ament=False)


def message(name: str) -> tuple[Any, dict[str, Any]]:
    """The case's message as a subscriber receives it (float32 values widened, for one)."""
    type_name, fields, options = CASES[name]
    cls = registry_for(type_name).get_class(type_name)
    return decode(cls, encode(cls(**fields))), options


@pytest.mark.parametrize('name', sorted(CASES))
def test_yaml_matches_ros2(name: str) -> None:
    msg, options = message(name)
    text = message_to_yaml(
        msg,
        flow_style=options.get('flow_style', False),
        truncate=options.get('truncate_length'),
        no_arr=options.get('no_arr', False),
        no_str=options.get('no_str', False),
    )
    assert text + '---\n' == (GOLDEN / f'{name}.yaml').read_text(encoding='utf-8')


@pytest.mark.parametrize('name', CSV_CASES)
def test_csv_matches_ros2(name: str) -> None:
    msg, options = message(name)
    text = message_to_csv(
        msg,
        truncate=options.get('truncate_length'),
        no_arr=options.get('no_arr', False),
        no_str=options.get('no_str', False),
    )
    assert text + '\n' == (GOLDEN / f'{name}.csv').read_text(encoding='utf-8')


def test_echo_prints_the_golden_text(cli: Cli, zros_node: Any) -> None:
    node = zros_node('golden')
    for name in ('imu', 'pose_array'):
        type_name, fields, _ = CASES[name]
        publisher = node.create_publisher(type_name, f'/{name}', 'latched')
        publisher.write(default_registry().get_class(type_name)(**fields))
        result = cli.run('topic', 'echo', f'/{name}', '--once')
        assert result.stdout == (GOLDEN / f'{name}.yaml').read_text(encoding='utf-8')
    csv = cli.run('topic', 'echo', '/imu', '--once', '--csv')
    assert csv.stdout == (GOLDEN / 'imu.csv').read_text(encoding='utf-8')


@given(st.text(st.sampled_from('yYnNoO01234567:.-+_eE~=!&* xabflsuT\n')))
def test_strings_are_quoted_as_pyyaml_quotes_them(text: str) -> None:
    """ros2 dumps with PyYAML: a string PyYAML would read back as a number, bool, null or date
    gets quotes, and zros agrees on every such string."""
    yaml = pytest.importorskip('yaml', reason='PyYAML (the reference dumper) comes with rclpy')
    expected = yaml.dump({'data': text}, allow_unicode=True, width=sys.maxsize)
    assert to_yaml({'data': text}) == expected
