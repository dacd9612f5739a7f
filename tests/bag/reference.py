"""What rosbags itself reports about the recordings of ../shared/testdata (the reference).

Folders are read file by file with rosbags' storage readers: its folder reader drops every
message of a topic whose QoS in metadata.yaml differs from the one in the storage file
(talker_mcap, talker_sqlite3), which is not what the recording holds.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

#: every recording, as a path zros opens
RECORDINGS = [
    'ros2/cdr_test_mcap',
    'ros2/cdr_test_sqlite3',
    'ros2/convert_b_mcap',
    'ros2/empty_bag',
    'ros2/legacy_type_names_mcap',
    'ros2/talker_mcap',
    'ros2/talker_sqlite3',
    'ros2/wbag_split_mcap',
    'ros2/padded_mcap/multiple_files_2.mcap',
    'ros2/services_and_topics/topics_and_services.mcap',
    'ros2/services_and_topics/topics_and_services.db3',
    'ros1/example-unsorted-chunks.bag',
    'ros1/fake_sensors_sample.bag',
]


def storage_files(path: Path) -> list[Path]:
    """The storage files of a recording path."""
    if path.is_dir():
        return sorted([*path.glob('*.mcap'), *path.glob('*.db3')])
    return [path]


def raw_messages(path: Path) -> list[tuple[str, str, int, bytes]]:
    """(topic, rosbags type name, timestamp, raw bytes) of every message, in time order."""
    found: list[tuple[str, str, int, bytes]] = []
    if path.suffix == '.bag':
        from rosbags.rosbag1 import Reader as Reader1

        with Reader1(path) as reader:
            for conn, timestamp, data in reader.messages():
                found.append((conn.topic, conn.msgtype, timestamp, bytes(data)))
        return found
    from rosbags.rosbag2 import Reader

    for file in storage_files(path):
        with Reader(file) as reader:
            for conn, timestamp, data in reader.messages():
                found.append((conn.topic, conn.msgtype, timestamp, bytes(data)))
    found.sort(key=lambda item: item[2])
    return found


def to_plain(value: Any) -> Any:
    """A rosbags message (or a zros ``to_dict``) as nested dicts, lists and numbers."""
    import numpy as np

    if hasattr(value, '__dataclass_fields__'):
        return {
            name: to_plain(getattr(value, name))
            for name in value.__dataclass_fields__
            if name not in ('__msgtype__', 'structure_needs_at_least_one_member')
        }
    if isinstance(value, dict):
        return {key: to_plain(item) for key, item in value.items()}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [to_plain(item) for item in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
