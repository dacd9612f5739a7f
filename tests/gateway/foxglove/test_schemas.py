"""The ``ros2msg`` schemas ``zros foxglove`` gives its channels are those rosbag2 writes into
MCAP files: the definition, then each dependency after a ``MSG: pkg/Type`` rule, in the same
order. zros does not keep the comments of ``.msg`` files (Foxglove's parser skips them), so the
texts are compared without comments and blank lines."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from zros.cdr import default_registry
from zros.cdr.registry import TypeRegistry

pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')

from zros.gateway.foxglove.sdk import ros2msg_schema

#: (recording, type): rosbag2 recordings of Jazzy-era types
STANDARD = [
    ('padded_mcap/multiple_files_2.mcap', 'std_msgs/msg/String'),
    ('services_and_topics/topics_and_services.mcap', 'rcl_interfaces/msg/Log'),
    ('services_and_topics/topics_and_services.mcap', 'rcl_interfaces/msg/ParameterEvent'),
]
#: types of the test_msgs package, known when the ROS wheels (interop extra) are installed
TEST_MSGS = [
    ('cdr_test_mcap/cdr_test_0.mcap', 'test_msgs/msg/BasicTypes'),
    ('cdr_test_mcap/cdr_test_0.mcap', 'test_msgs/msg/Arrays'),
    ('convert_b_mcap/rewriter_b_0.mcap', 'test_msgs/msg/Empty'),
]


def _without_comments(text: str) -> list[str]:
    lines = []
    for line in text.splitlines():
        kept = line
        if not line.startswith('=' * 80):
            kept = re.sub(r'\s+', ' ', re.sub(r'(^|\s)#.*$', '', line)).strip()
        if kept:
            lines.append(kept)
    return lines


def _recorded(testdata: Path, recording: str, type_name: str) -> str:
    from mcap.reader import make_reader

    with (testdata / 'ros2' / recording).open('rb') as file:
        summary = make_reader(file).get_summary()
    assert summary is not None
    (schema,) = [s for s in summary.schemas.values() if s.name == type_name][:1]
    assert schema.encoding == 'ros2msg'
    return str(schema.data.decode())


@pytest.mark.parametrize(('recording', 'type_name'), STANDARD)
def test_schemas_match_rosbag2(testdata: Path, recording: str, type_name: str) -> None:
    schema = ros2msg_schema(default_registry(), type_name)
    assert (schema.name, schema.encoding) == (type_name, 'ros2msg')
    ours = schema.data.decode()
    assert _without_comments(ours) == _without_comments(_recorded(testdata, recording, type_name))
    assert '#' not in ours


@pytest.mark.parametrize(('recording', 'type_name'), TEST_MSGS)
def test_schemas_match_rosbag2_for_the_ros_wheels_types(
    testdata: Path, recording: str, type_name: str
) -> None:
    share = Path(sys.prefix) / 'share' / 'test_msgs'
    if not share.is_dir():
        pytest.skip('test_msgs (the ROS wheels of the interop extra) is not installed')
    registry = TypeRegistry('jazzy', paths=[share.parent], ament=False)
    ours = ros2msg_schema(registry, type_name).data.decode()
    assert _without_comments(ours) == _without_comments(_recorded(testdata, recording, type_name))


def test_an_unknown_type_has_no_schema(caplog: pytest.LogCaptureFixture) -> None:
    assert ros2msg_schema(default_registry(), 'nope_msgs/msg/Nothing') is None
    assert 'no definition of nope_msgs/msg/Nothing' in caplog.text
