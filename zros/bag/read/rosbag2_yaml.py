"""The YAML rosbag2 writes: ``metadata.yaml`` and the ``offered_qos_profiles`` of a topic.

Metadata is written in version 8 of the format (QoS policies as numbers, the profiles as one
YAML string), laid out as yaml-cpp lays it out. Version 8 is what every rosbag2 since Humble
reads (Humble skips the keys it does not know; version 9 turned the profiles into a list Humble
cannot parse), and what ``rosbags`` reads too.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from zros.qos import Durability, History, QoS, Reliability

if TYPE_CHECKING:
    from zros.bag.boundary import YamlValue

_P = TypeVar('_P')

METADATA_VERSION = 8
#: rmw's RMW_DURATION_INFINITE as rosbag2 writes it (Jazzy on)
INFINITE = {'sec': 9223372036, 'nsec': 854775807}
#: starting_time of a bag without messages (time_point::max)
NO_START = 2**63 - 1

# rmw enum values (rmw/types.h)
_HISTORY = {History.KEEP_LAST: 1, History.KEEP_ALL: 2}
_RELIABILITY = {Reliability.RELIABLE: 1, Reliability.BEST_EFFORT: 2}
_DURABILITY = {Durability.TRANSIENT_LOCAL: 1, Durability.VOLATILE: 2}
_LIVELINESS_AUTOMATIC = 1


@dataclass(frozen=True)
class TopicEntry:
    """One topic of ``topics_with_message_count``."""

    name: str
    type_name: str
    offered_qos_profiles: str
    type_hash: str
    message_count: int
    serialization_format: str = 'cdr'


@dataclass(frozen=True)
class FileEntry:
    """One storage file of ``files``."""

    path: str
    start_ns: int
    duration_ns: int
    message_count: int


# --- QoS -------------------------------------------------------------------------------------


def qos_profile(qos: QoS) -> dict[str, YamlValue]:
    """A QoS as rosbag2 stores one offered profile (rmw numbers, infinite durations)."""
    return {
        'history': _HISTORY[qos.history],
        'depth': 0 if qos.keep_all else qos.depth,
        'reliability': _RELIABILITY[qos.reliability],
        'durability': _DURABILITY[qos.durability],
        'deadline': dict(INFINITE),
        'lifespan': dict(INFINITE),
        'liveliness': _LIVELINESS_AUTOMATIC,
        'liveliness_lease_duration': dict(INFINITE),
        'avoid_ros_namespace_conventions': False,
    }


def qos_profiles_text(profiles: Sequence[QoS]) -> str:
    """The ``offered_qos_profiles`` string (channel metadata and metadata.yaml, version 8)."""
    return '\n'.join(line for qos in profiles for line in _list_item(qos_profile(qos), 0))


def _policy(value: object, names: Mapping[str, int], numbers: Mapping[int, _P]) -> _P | None:
    """A policy given as an rmw number (version 8) or name (version 9); None if unknown."""
    if isinstance(value, bool):
        return None
    if isinstance(value, str):
        number = names.get(value.strip().lower())
        return None if number is None else numbers.get(number)
    if isinstance(value, int):
        return numbers.get(value)
    return None


def parse_qos_profiles(profiles: str | Sequence[Mapping[str, YamlValue]] | None) -> list[QoS]:
    """Offered profiles (a YAML string or a list of mappings) as zros QoS values.

    Unknown or system-default policies take ROS 2's defaults (reliable, volatile, keep last);
    a depth of 0 (DDS reports none) becomes 10.
    """
    if not profiles:
        return []
    if isinstance(profiles, str):
        from ruamel.yaml import YAML  # noqa: PLC0415 (lazy: ruamel.yaml, import time)
        from ruamel.yaml.error import YAMLError  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

        try:
            loaded = YAML(typ='safe', pure=True).load(profiles)
        except YAMLError as exc:
            raise ValueError(f'offered_qos_profiles is not valid YAML: {exc}') from None
        if not loaded:
            return []
        if not isinstance(loaded, list):
            raise ValueError('offered_qos_profiles is not a list of profiles')
        items: Sequence[object] = loaded
    else:
        items = profiles
    result = []
    for item in items:
        if not isinstance(item, Mapping):
            raise ValueError(f'a QoS profile must be a mapping, not {item!r}')
        history = _policy(
            item.get('history'),
            {'keep_last': 1, 'keep_all': 2},
            {1: History.KEEP_LAST, 2: History.KEEP_ALL},
        )
        reliability = _policy(
            item.get('reliability'),
            {'reliable': 1, 'best_effort': 2},
            {1: Reliability.RELIABLE, 2: Reliability.BEST_EFFORT},
        )
        durability = _policy(
            item.get('durability'),
            {'transient_local': 1, 'volatile': 2},
            {1: Durability.TRANSIENT_LOCAL, 2: Durability.VOLATILE},
        )
        depth = item.get('depth')
        depth = depth if isinstance(depth, int) and not isinstance(depth, bool) and depth > 0 else 0
        result.append(
            QoS(
                depth or 10,
                Reliability.RELIABLE if reliability is None else reliability,
                Durability.VOLATILE if durability is None else durability,
                History.KEEP_LAST if history is None else history,
            )
        )
    return result


# --- metadata.yaml ---------------------------------------------------------------------------

_PLAIN = re.compile(r'[A-Za-z_/][A-Za-z0-9_/.\-]*')
_RESERVED = {'true', 'false', 'yes', 'no', 'on', 'off', 'y', 'n', 'null', '~'}


def _scalar(value: object) -> str:
    if value is None:
        return '~'
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, int):
        return str(value)
    text = str(value)
    if _PLAIN.fullmatch(text) and text.lower() not in _RESERVED:
        return text
    return json.dumps(text)  # a JSON string is a YAML double-quoted scalar


def _mapping(value: Mapping[str, object], indent: int) -> list[str]:
    """A mapping in block style, yaml-cpp's way (sequences indented under their key)."""
    lines: list[str] = []
    pad = ' ' * indent
    for key, item in value.items():
        if isinstance(item, Mapping) and item:
            lines.append(f'{pad}{key}:')
            lines.extend(_mapping(item, indent + 2))
        elif isinstance(item, list) and item:
            lines.append(f'{pad}{key}:')
            for element in item:
                lines.extend(_list_item(element, indent + 2))
        elif isinstance(item, Mapping):
            lines.append(f'{pad}{key}: {{}}')
        elif isinstance(item, list):
            lines.append(f'{pad}{key}: []')
        else:
            lines.append(f'{pad}{key}: {_scalar(item)}')
    return lines


def _list_item(element: object, indent: int) -> list[str]:
    if isinstance(element, Mapping) and element:
        lines = _mapping(element, indent + 2)
        lines[0] = ' ' * indent + '- ' + lines[0][indent + 2 :]
        return lines
    return [' ' * indent + '- ' + _scalar(element)]


def bag_metadata(
    files: Sequence[FileEntry],
    topics: Sequence[TopicEntry],
    ros_distro: str = '',
    custom_data: Mapping[str, str] | None = None,
    storage_identifier: str = 'mcap',
) -> dict[str, YamlValue]:
    """The ``rosbag2_bagfile_information`` mapping, in rosbag2's key order."""
    used = [f for f in files if f.message_count]
    start = min((f.start_ns for f in used), default=NO_START)
    end = max((f.start_ns + f.duration_ns for f in used), default=NO_START)
    return {
        'version': METADATA_VERSION,
        'storage_identifier': storage_identifier,
        'duration': {'nanoseconds': end - start},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': sum(f.message_count for f in files),
        'topics_with_message_count': [
            {
                'topic_metadata': {
                    'name': t.name,
                    'type': t.type_name,
                    'serialization_format': t.serialization_format,
                    'offered_qos_profiles': t.offered_qos_profiles,
                    'type_description_hash': t.type_hash,
                },
                'message_count': t.message_count,
            }
            for t in topics
        ],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [f.path for f in files],
        'files': [
            {
                'path': f.path,
                'starting_time': {
                    'nanoseconds_since_epoch': f.start_ns if f.message_count else NO_START
                },
                'duration': {'nanoseconds': f.duration_ns},
                'message_count': f.message_count,
            }
            for f in files
        ],
        'custom_data': dict(custom_data) if custom_data else None,
        'ros_distro': ros_distro,
    }


def dump(value: Mapping[str, object]) -> str:
    """A mapping as yaml-cpp dumps it (block style, two-space indents)."""
    return '\n'.join(_mapping(value, 0)) + '\n'


def metadata_yaml(metadata: Mapping[str, object]) -> str:
    """The text of ``metadata.yaml`` for a ``rosbag2_bagfile_information`` mapping."""
    return dump({'rosbag2_bagfile_information': metadata})


def distro_and_custom(text: str) -> tuple[str, dict[str, str]]:
    """The ROS distro and ``custom_data`` of rosbag2 metadata (the text of ``metadata.yaml``,
    or the ``serialized_metadata`` an MCAP file holds, which lacks the outer key); empty where
    it does not parse."""
    from ruamel.yaml import YAML  # noqa: PLC0415 (lazy: ruamel.yaml, import time)
    from ruamel.yaml.error import YAMLError  # noqa: PLC0415 (lazy: ruamel.yaml, import time)

    try:
        loaded = YAML(typ='safe', pure=True).load(text)
        info = loaded.get('rosbag2_bagfile_information', loaded)
        distro = info.get('ros_distro') or ''
        custom = info.get('custom_data') or {}
    except (YAMLError, KeyError, TypeError, AttributeError):
        return '', {}
    if not isinstance(distro, str) or not isinstance(custom, dict):
        return '', {}
    return distro, {str(k): str(v) for k, v in custom.items()}


def write_metadata_yaml(folder: Path, metadata: Mapping[str, object]) -> Path:
    """Write ``folder/metadata.yaml`` through a temporary file renamed over it, so a process
    killed meanwhile leaves the old file or the new one, never half of one."""
    path = folder / 'metadata.yaml'
    temporary = folder / '.metadata.yaml.tmp'
    try:
        with temporary.open('w', encoding='utf-8') as stream:
            stream.write(metadata_yaml(metadata))
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path
