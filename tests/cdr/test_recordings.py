"""Every message recorded by real ROS 2 tools decodes and re-encodes to its bytes.

Definitions come from the recording where it embeds them; one recording (talker_sqlite3) embeds
wrong ones, which the data then contradicts: for those the standard definition is used.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from pathlib import Path

import pytest

from zros import cdr
from zros.cdr.model import split_type_name, type_name_candidates
from zros.cdr.registry import TypeRegistry

#: recordings whose embedded definitions disagree with their data (SOURCES.md says so; the
#: ParameterEvent definition there is wrong too, but the recording holds no such message)
WRONG_DEFINITIONS = {('talker.db3', 'rcl_interfaces/msg/Log')}
EXPECTED_COUNTS = {
    'cdr_test_0.mcap': 7,
    'cdr_test_0.db3': 7,
    'rewriter_b_0.mcap': 75,
    'empty_bag_0.db3': 0,
    'test_bag_for_seek_0.mcap': 5,
    'multiple_files_2.mcap': 529,
    'topics_and_services.mcap': 13,
    'topics_and_services.db3': 13,
    'talker.mcap': 20,
    'talker.db3': 20,
    'wbag_0.mcap': 1246,
    'wbag_1.mcap': 1240,
    'wbag_2.mcap': 1240,
    'wbag_3.mcap': 1240,
    'wbag_4.mcap': 1108,
    'nav2_turtlebot.mcap': 8197,
    'rosbagFrankaPandaRos2.bag.db3': 112,
    'tf_example.db3': 518,
}

Record = tuple[str, str, bytes]  # type name, embedded definition, message bytes


def _mcap_records(path: Path) -> Iterator[Record]:
    from mcap.reader import make_reader

    with path.open('rb') as stream:
        for schema, _channel, message in make_reader(stream).iter_messages():
            assert schema is not None
            yield schema.name, schema.data.decode(), message.data


def _db3_records(path: Path) -> Iterator[Record]:
    db = sqlite3.connect(f'file:{path}?mode=ro', uri=True)
    try:
        tables = {row[0] for row in db.execute("select name from sqlite_master where type='table'")}
        definitions: dict[str, str] = {}
        if 'message_definitions' in tables:
            definitions = dict(
                db.execute('select topic_type, encoded_message_definition from message_definitions')
            )
        query = (
            'select t.type, m.data from messages m join topics t on m.topic_id = t.id order by m.id'
        )
        for type_name, data in db.execute(query):
            text = definitions.get(type_name)
            if text is None and type_name.endswith('_Event'):
                text = definitions.get(type_name[: -len('_Event')])
            yield type_name, text or '', bytes(data)
    finally:
        db.close()


def _register(registry: TypeRegistry, type_name: str, text: str) -> str:
    """Register an embedded definition; returns the full message name to decode with."""
    name = type_name_candidates(type_name)[0]
    package, kind, short = split_type_name(name)
    if kind == 'srv' and short.endswith('_Event') and '---' in text:
        # service events store the .srv text of their service
        registry.register_text(f'{package}/srv/{short[: -len("_Event")]}', text)
    elif text:
        registry.register_bundle(name, text, str(name), override_dependencies=True)
    elif registry.find(name) is None:
        registry.register_text(name, '')  # an empty message stores an empty definition
    return name


def _recordings(root: Path) -> list[Path]:
    return sorted([*root.glob('ros2/**/*.mcap'), *root.glob('ros2/**/*.db3')])


def test_every_recorded_message_decodes_and_re_encodes(testdata: Path) -> None:
    standard = TypeRegistry('jazzy', paths=[], ament=False)
    counts: dict[str, int] = {}
    fallbacks: set[tuple[str, str]] = set()
    differing_bytes = 0
    for path in _recordings(testdata):
        registry = TypeRegistry('jazzy', paths=[], ament=False)
        reader = _mcap_records if path.suffix == '.mcap' else _db3_records
        counts[path.name] = 0
        for type_name, text, raw in reader(path):
            name = _register(registry, type_name, text)
            try:
                message = cdr.decode(registry.get_class(name), raw, strict=True)
            except cdr.CdrError:
                fallbacks.add((path.name, name))
                message = cdr.decode(standard.get_class(name), raw)
            encoded = cdr.encode(message)
            # the recording may carry up to 3 bytes of trailing padding
            assert 0 <= len(raw) - len(encoded) <= 3, (path.name, name)
            # where the bytes differ, the recorded ones are padding: decoding ignores them
            differing = [i for i in range(len(encoded)) if raw[i] != encoded[i]]
            assert all(encoded[i] == 0 for i in differing)
            assert type(message).deserialize(encoded) == message
            differing_bytes += len(differing)
            counts[path.name] += 1
    assert counts == EXPECTED_COUNTS
    assert fallbacks == WRONG_DEFINITIONS
    # talker_mcap holds two Log messages with non-zero bytes in alignment padding
    assert differing_bytes > 0


def test_embedded_definitions_are_used(testdata: Path) -> None:
    registry = TypeRegistry('jazzy', paths=[], ament=False)
    records = list(_mcap_records(testdata / 'ros2' / 'cdr_test_mcap' / 'cdr_test_0.mcap'))
    for type_name, text, raw in records:
        cls = registry.get_class(_register(registry, type_name, text))
        assert cls._definition.origin == _register(registry, type_name, text)
        cdr.decode(cls, raw)
    arrays = registry.get_class('test_msgs/msg/Arrays')
    assert arrays._field_types['string_values_default'] == 'string[3]'


def test_wrong_embedded_definition_is_detected(testdata: Path) -> None:
    registry = TypeRegistry('jazzy', paths=[], ament=False)
    for type_name, text, raw in _db3_records(testdata / 'ros2' / 'talker_sqlite3' / 'talker.db3'):
        if type_name == 'rcl_interfaces/msg/Log':
            assert text == 'uint8 level'
            cls = registry.get_class(_register(registry, type_name, text))
            with pytest.raises(cdr.CdrError, match='bytes left after the end of the message'):
                cdr.decode(cls, raw, strict=True)
            # lenient decoding would give garbage: the first byte of the stamp as the level
            assert cdr.decode(cls, raw).level == raw[4]
            return
    raise AssertionError('no Log message found')
