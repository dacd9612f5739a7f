"""The reference ``ros2 interface show`` text, made with ROS's own tooling.

ros2interface is not on PyPI, so this module runs its algorithm (ros2/ros2cli, branch jazzy,
``ros2interface/verb/show.py``: ``_show_interface`` and ``InterfaceTextLine``) on the real line
parser, ``rosidl_adapter.parser.parse_message_string``, over the interface files the ROS 2
Jazzy wheels of the interop extra install under ``<sys.prefix>/share``. Nothing of zros is used.

The golden texts are made when the tests run rather than stored: they are the upstream files'
text (comments included), which the repository does not copy. ``python -m
tests.cli.ros2_interface_show DIR`` writes them into DIR to look at.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

SHARE = Path(sys.prefix) / 'share'

#: type -> why it is a case
INTERFACE_CASES = {
    'std_msgs/msg/Header': 'comments, a nested type',
    'geometry_msgs/msg/PoseStamped': 'nested two deep, default values (Quaternion)',
    'sensor_msgs/msg/Image': 'indented comment lines, arrays',
    'sensor_msgs/msg/Range': 'constants, trailing comments with [units]',
    'sensor_msgs/msg/NavSatFix': 'constants in a nested type, fixed arrays',
    'visualization_msgs/msg/Marker': 'many nested types, sequences of them',
    'rcl_interfaces/msg/ParameterDescriptor': 'bounded sequences of nested types',
    'diagnostic_msgs/msg/DiagnosticArray': 'sequences of nested types, byte constants',
    'std_srvs/srv/SetBool': 'a service',
    'action_msgs/srv/CancelGoal': 'a service with constants and nested types',
    'test_msgs/action/Fibonacci': 'an action: two separators',
}
MODES = {'': (True, False), '.no-comments': (False, False), '.all-comments': (True, True)}


def available() -> bool:
    """Whether the ROS 2 wheels (interface files, rosidl_adapter) are installed here."""
    try:
        import rosidl_adapter.parser  # noqa: F401
    except ImportError:
        return False
    return (SHARE / 'ament_index').is_dir()


def _line_info(package: str, name: str, text: str) -> tuple[bool, str | None, str | None]:
    """(is a comment, trailing comment, nested type) as ros2interface's InterfaceTextLine."""
    from rosidl_adapter.parser import parse_message_string

    if text == '---':
        return False, None, None
    spec: Any = parse_message_string(pkg_name=package, msg_name=name, message_string=text)
    is_comment = bool(spec.annotations['comment'])
    field = spec.fields[0] if spec.fields else None
    constant = spec.constants[0] if spec.constants else None
    trailing = None
    if field is not None and field.annotations['comment']:
        trailing = field.annotations['comment'][0]
    elif constant is not None and constant.annotations['comment']:
        trailing = constant.annotations['comment'][0]
    nested = None
    if field is not None and '/' in str(field.type):
        type_text = str(field.type)
        if field.type.is_array:
            type_text = type_text[: type_text.find('[')]
        nested = type_text.replace('/', '/msg/')
    return is_comment, trailing, nested


def show(type_name: str, comments: bool, nested_comments: bool, depth: int = 0) -> list[str]:
    """The lines ros2interface prints for ``type_name``."""
    package, kind, name = type_name.split('/')
    path = SHARE / package / kind / f'{name}.{kind}'
    out: list[str] = []
    with path.open(encoding='utf-8') as file:
        for raw in file:
            text = raw.rstrip()
            is_comment, trailing, nested = _line_info(package, name, text)
            hidden = not comments and (not text or is_comment)
            if not comments and not hidden and trailing is not None:
                text = text[: text.find(trailing) - 1].strip()
            if not hidden:
                out.append('\t' * depth + text if text else '')
            if nested:
                out += show(nested, nested_comments, nested_comments, depth + 1)
    return out


def reference_text(type_name: str, mode: str) -> str:
    """What ``ros2 interface show TYPE`` prints in ``mode`` (a key of ``MODES``)."""
    comments, nested_comments = MODES[mode]
    return ''.join(line + '\n' for line in show(type_name, comments, nested_comments))


def main() -> None:
    """Write every case in every mode into the folder given as argument."""
    folder = Path(sys.argv[1])
    folder.mkdir(parents=True, exist_ok=True)
    for type_name in INTERFACE_CASES:
        for mode in MODES:
            path = folder / (type_name.replace('/', '.') + mode + '.txt')
            path.write_text(reference_text(type_name, mode), encoding='utf-8')
            print(path)


if __name__ == '__main__':
    main()
