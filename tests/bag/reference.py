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


def _normalise(name: str) -> str:
    parts = name.split('/')
    return f'{parts[0]}/msg/{parts[1]}' if len(parts) == 2 else name


def _event_types(name: str, text: str, standard: Any) -> dict[str, Any]:
    """rosbags types of a service event, from the .srv text rosbag2 stores for it.

    rosbags parses each half of the .srv; the event wraps them as rosidl does:
    ``ServiceEventInfo info``, ``Request[<=1] request``, ``Response[<=1] response``.
    """
    from rosbags.interfaces import Nodetype
    from rosbags.typesys import get_types_from_msg

    service = name[: -len('_Event')]
    request, response = text.split('\n---', 1)
    types: dict[str, Any] = {}
    for part, text_of_part in (('_Request', request), ('_Response', response.lstrip('-\n'))):
        # rosbags names a message of a srv package pkg/srv/msg/Name: parse under a plain name
        parsed = get_types_from_msg(text_of_part, 'zros_reference/msg/Part')
        types[service + part] = parsed.pop('zros_reference/msg/Part')
        types.update(parsed)
    info = 'service_msgs/msg/ServiceEventInfo'
    for dependency in (info, 'builtin_interfaces/msg/Time'):
        types[dependency] = standard.fielddefs[dependency]
    types[name] = (
        [],
        [
            ('info', (Nodetype.NAME, info)),
            ('request', (Nodetype.SEQUENCE, ((Nodetype.NAME, service + '_Request'), 1))),
            ('response', (Nodetype.SEQUENCE, ((Nodetype.NAME, service + '_Response'), 1))),
        ],
    )
    return types


def rosbags_messages(path: Path) -> list[tuple[str, str, int, Any]]:
    """(topic, type name, timestamp, message) as rosbags decodes them, in time order.

    Types come from the definitions in the recording; where rosbags finds the data does not
    fit one (its size check), from its Jazzy typestore, as zros does.
    """
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import Reader
    from rosbags.serde import SerdeError
    from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore

    found: list[tuple[str, str, int, Any]] = []
    if path.suffix == '.bag':
        with AnyReader([path]) as reader:
            for conn, timestamp, data in reader.messages():
                message = reader.deserialize(data, conn.msgtype)
                found.append((conn.topic, conn.msgtype, timestamp, message))
        return found
    standard = get_typestore(Stores.ROS2_JAZZY)
    for file in storage_files(path):
        with Reader(file) as reader:
            types: dict[str, Any] = {}
            for conn in reader.connections:
                name, text = _normalise(conn.msgtype), conn.msgdef.data
                if not text and name.endswith('_Event'):
                    # a db3 stores the .srv text under the service's name
                    service = name[: -len('_Event')]
                    entries = getattr(reader.storage, 'msgtypes', [])
                    text = next((e['msgdef'] for e in entries if e['name'] == service), '')
                if name.endswith('_Event') and '---' in text:
                    types.update(_event_types(name, text, standard))
                elif conn.msgdef.format.name == 'MSG':
                    types.update(get_types_from_msg(text, name))
                elif conn.msgdef.format.name == 'IDL':
                    types.update(get_types_from_idl(text))
            embedded = get_typestore(Stores.EMPTY)
            embedded.register(types)
            for conn, timestamp, data in reader.messages():
                name = _normalise(conn.msgtype)
                try:
                    message = embedded.deserialize_cdr(data, name)
                except (SerdeError, KeyError):
                    message = standard.deserialize_cdr(data, name)
                found.append((conn.topic, name, timestamp, message))
    found.sort(key=lambda item: item[2])
    return found


def assert_same(mine: Any, theirs: Any, where: str = '') -> None:
    """A zros message equals a rosbags one field by field (ROS 1 ``Header.seq`` aside).

    ``byte`` is an octet to zros and int8 to rosbags: compared modulo 256.
    """
    import dataclasses

    import numpy as np

    from zros.cdr.naming import attribute_name

    definition = type(mine)._definition
    names = {attribute_name(f.name) for f in definition.fields}
    constants = {c.name for c in definition.constants}
    extra = {f.name for f in dataclasses.fields(theirs)} - names - constants - {'__msgtype__'}
    extra -= {'structure_needs_at_least_one_member'}
    if definition.name == 'std_msgs/msg/Header':
        extra -= {'seq'}
    assert not extra, f'{where}: rosbags has fields zros lacks: {extra}'
    for constant in definition.constants:
        assert getattr(type(mine), constant.name) == getattr(theirs, constant.name), where
    for f in definition.fields:
        name = attribute_name(f.name)
        at = f'{where}.{f.name}'
        a, b = getattr(mine, name), getattr(theirs, name)
        t = f.type
        if t.is_nested:
            if t.kind.name == 'SCALAR':
                assert_same(a, b, at)
            else:
                assert len(a) == len(b), at
                for index, (x, y) in enumerate(zip(a, b, strict=True)):
                    assert_same(x, y, f'{at}[{index}]')
        elif t.is_string:
            assert (list(a) if t.kind.name != 'SCALAR' else a) == (
                list(b) if t.kind.name != 'SCALAR' else b
            ), at
        else:
            left, right = np.asarray(a), np.asarray(b)
            if t.base == 'byte':
                right = right.astype(np.int64) % 256
            assert left.shape == right.shape, at
            if left.dtype.kind == 'f':
                assert np.array_equal(left, right, equal_nan=True), at
            else:
                assert np.array_equal(
                    left.astype(np.int64) if left.dtype == bool else left,
                    right.astype(np.int64) if right.dtype == bool else right,
                ), at
