"""RIHS01 type hashes, checked against the JSON files and the generator of the ROS wheels."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

from zros import cdr
from zros.cdr.builtin import builtin_names
from zros.cdr.errors import UnknownTypeError
from zros.cdr.hashing import hash_description, type_description, type_hash
from zros.cdr.parser import parse_message
from zros.cdr.registry import TypeRegistry

SHARE = Path(sys.prefix) / 'share'
JSON_FILES = sorted(
    path
    for path in SHARE.glob('*/*/*.json')
    if path.parent.name in ('msg', 'srv', 'action')
    and path.with_suffix('.' + path.parent.name).is_file()
)

if not JSON_FILES:
    pytest.skip(
        f'no rosidl type description .json files under {SHARE} (the ROS wheels of the '
        '"interop" extra are not installed)',
        allow_module_level=True,
    )

KNOWN = {
    'std_msgs/msg/String': (
        'RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18'
    ),
    'example_interfaces/srv/AddTwoInts': (
        'RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a'
    ),
}


@pytest.fixture(scope='module')
def installed() -> TypeRegistry:
    """A registry reading definitions from the .msg/.srv/.action files of the ROS wheels."""
    return TypeRegistry('jazzy', paths=[SHARE], ament=False)


@pytest.fixture(scope='module')
def jazzy() -> TypeRegistry:
    return TypeRegistry('jazzy', ament=False)


@pytest.fixture(scope='module')
def humble() -> TypeRegistry:
    return TypeRegistry('humble', ament=False)


def _json_id(path: Path) -> str:
    return '/'.join(path.parts[-3:])


def _without_defaults(description: dict[str, Any]) -> dict[str, Any]:
    def strip(individual: dict[str, Any]) -> dict[str, Any]:
        fields = [
            {k: v for k, v in f.items() if k != 'default_value'} for f in individual['fields']
        ]
        return {'type_name': individual['type_name'], 'fields': fields}

    return {
        'type_description': strip(description['type_description']),
        'referenced_type_descriptions': [
            strip(d) for d in description['referenced_type_descriptions']
        ],
    }


# --- known values ---------------------------------------------------------------------------


@pytest.mark.parametrize('name', sorted(KNOWN))
def test_known_hashes(jazzy: TypeRegistry, name: str) -> None:
    assert type_hash(jazzy, name) == KNOWN[name]


def test_package_level_type_hash(jazzy: TypeRegistry) -> None:
    previous = cdr.default_registry()
    cdr.set_default_registry(jazzy)
    try:
        assert cdr.type_hash('std_msgs/msg/String') == KNOWN['std_msgs/msg/String']
        assert cdr.type_hash(cdr.get_class('std_msgs/msg/String')) == KNOWN['std_msgs/msg/String']
    finally:
        cdr.set_default_registry(previous)


def test_short_names(jazzy: TypeRegistry) -> None:
    assert type_hash(jazzy, 'std_msgs/String') == KNOWN['std_msgs/msg/String']
    assert (
        type_hash(jazzy, 'example_interfaces/AddTwoInts')
        == KNOWN['example_interfaces/srv/AddTwoInts']
    )


def test_unknown_type(jazzy: TypeRegistry) -> None:
    with pytest.raises(UnknownTypeError):
        type_hash(jazzy, 'nope_msgs/msg/Nothing')
    with pytest.raises(UnknownTypeError):
        type_hash(jazzy, 'std_srvs/srv/SetBool_Nothing')


# --- oracle: the JSON files generated with the ROS wheels -----------------------------------


@pytest.mark.parametrize('path', JSON_FILES, ids=_json_id)
def test_installed_json_hashes(installed: TypeRegistry, path: Path) -> None:
    content = json.loads(path.read_text(encoding='utf-8'))
    assert content['type_hashes'], f'{path} lists no hashes'
    mismatches = []
    for entry in content['type_hashes']:
        try:
            ours = type_hash(installed, entry['type_name'])
        except Exception as error:
            ours = f'{type(error).__name__}: {error}'
        if ours != entry['hash_string']:
            mismatches.append(f'{entry["type_name"]}: expected {entry["hash_string"]}, got {ours}')
    assert not mismatches, f'{len(mismatches)} hash mismatch(es) in {path}:\n' + '\n'.join(
        mismatches
    )


@pytest.mark.parametrize('path', JSON_FILES, ids=_json_id)
def test_installed_json_descriptions(installed: TypeRegistry, path: Path) -> None:
    expected = json.loads(path.read_text(encoding='utf-8'))['type_description_msg']
    name = expected['type_description']['type_name']
    ours = type_description(installed, name)
    assert _without_defaults(ours) == _without_defaults(expected)
    # The default value texts are not hashed, but zros renders them as rosidl does.
    assert ours == expected
    assert hash_description(expected) == type_hash(installed, name)


def test_installed_json_count() -> None:
    entries = sum(len(json.loads(p.read_text(encoding='utf-8'))['type_hashes']) for p in JSON_FILES)
    kinds = {p.parent.name for p in JSON_FILES}
    assert kinds == {'msg', 'srv', 'action'}
    assert entries > len(JSON_FILES)


# --- oracle: the official generator ---------------------------------------------------------

GENERATOR_TYPES = [
    'std_msgs/msg/Empty',
    'test_msgs/msg/Arrays',
    'test_msgs/msg/Defaults',
    'test_msgs/msg/WStrings',
    'test_msgs/msg/BoundedSequences',
    'test_msgs/msg/MultiNested',
    'test_msgs/srv/BasicTypes',
    'test_msgs/srv/Empty',
    'test_msgs/action/Fibonacci',
    'test_msgs/action/NestedMessage',
]


def _generator_description(name: str) -> dict[str, Any]:
    """The full description rosidl_generator_type_description builds from the .idl files."""
    pytest.importorskip('lark', reason='rosidl_parser needs lark')
    generator = pytest.importorskip('rosidl_generator_type_description')
    parser = pytest.importorskip('rosidl_parser.parser')
    definition = pytest.importorskip('rosidl_parser.definition')

    individual: dict[str, Any] = {}
    parsed: set[str] = set()
    pending = [name]
    while pending:
        current = pending.pop()
        if current in individual or current in parsed:
            continue
        package, kind, short = current.split('/')
        parsed.add(current)
        locator = definition.IdlLocator(SHARE / package, Path(kind) / f'{short}.idl')
        for element in parser.parse_idl_file(locator).content.elements:
            if isinstance(element, definition.Message):
                generator.add_msg(element, individual)
            elif isinstance(element, definition.Service):
                generator.add_srv(element, individual)
            elif isinstance(element, definition.Action):
                generator.add_action(element, individual)
        for interface in list(individual.values()):
            for member in interface.members:
                member_type = member.type
                if isinstance(member_type, definition.AbstractNestedType):
                    member_type = member_type.value_type
                if isinstance(member_type, definition.NamespacedType):
                    nested = generator.to_type_name(member_type)
                    if nested not in individual:
                        pending.append(nested)
    serialized = {
        key: generator.serialize_individual_type_description(value.namespaced_type, value.members)
        for key, value in individual.items()
    }
    result: dict[str, Any] = generator.extract_full_type_description(name, serialized)
    result['hash'] = generator.calculate_type_hash(result)
    return result


@pytest.mark.parametrize('name', GENERATOR_TYPES)
def test_generator_oracle(installed: TypeRegistry, name: str) -> None:
    expected = _generator_description(name)
    expected_hash = expected.pop('hash')
    assert type_hash(installed, name) == expected_hash
    assert _without_defaults(type_description(installed, name)) == _without_defaults(expected)


# --- every known type -----------------------------------------------------------------------


def test_every_humble_message(humble: TypeRegistry) -> None:
    names = sorted(humble.typestore.fielddefs)
    assert len(names) > 100
    hashes = {name: type_hash(humble, name) for name in names}
    assert all(h.startswith('RIHS01_') and len(h) == 7 + 64 for h in hashes.values())
    assert len(set(hashes.values())) == len(hashes)


def test_every_jazzy_message(jazzy: TypeRegistry, installed: TypeRegistry) -> None:
    for name in sorted(jazzy.typestore.fielddefs):
        ours = type_hash(jazzy, name)
        assert ours.startswith('RIHS01_')
        if (SHARE / name).with_suffix('.json').is_file():
            # rosbags' jazzy typestore and the installed .msg files describe the same types
            assert ours == type_hash(installed, name), name


HUMBLE_MISSING = {
    'rcl_interfaces/srv/GetLoggerLevels',
    'rcl_interfaces/srv/SetLoggerLevels',
    'type_description_interfaces/srv/GetTypeDescription',
}


def _derived(name: str) -> list[str]:
    if '/srv/' in name:
        return [name + suffix for suffix in ('_Request', '_Response', '_Event')]
    parts = ['_Goal', '_Result', '_Feedback', '_FeedbackMessage']
    for service in ('_SendGoal', '_GetResult'):
        parts += [service + s for s in ('', '_Request', '_Response', '_Event')]
    return [name + suffix for suffix in parts]


@pytest.mark.parametrize('distro', ['jazzy', 'humble'])
def test_builtins(distro: str, jazzy: TypeRegistry, humble: TypeRegistry) -> None:
    registry = jazzy if distro == 'jazzy' else humble
    for name in builtin_names():
        if distro == 'humble' and name in HUMBLE_MISSING:
            # These services use messages that appeared in Iron.
            with pytest.raises(UnknownTypeError):
                type_hash(registry, name)
            continue
        for each in [name, *_derived(name)]:
            ours = type_hash(registry, each)
            # Humble services have no _Event message, but their hashes are those of Iron+.
            assert ours == type_hash(jazzy, each), each


def test_builtins_match_installed(jazzy: TypeRegistry, installed: TypeRegistry) -> None:
    compared = 0
    for name in builtin_names():
        if (SHARE / name).with_suffix('.json').is_file():
            assert type_hash(jazzy, name) == type_hash(installed, name), name
            compared += 1
    assert compared >= 5


# --- sensitivity and caching ----------------------------------------------------------------


def test_changes_change_the_hash() -> None:
    registry = TypeRegistry('jazzy', ament=False)
    registry.register_text('demo_msgs/msg/Inner', 'int32 x')
    registry.register_text('demo_msgs/msg/Outer', 'demo_msgs/Inner inner\nstring name')
    outer = type_hash(registry, 'demo_msgs/msg/Outer')
    inner = type_hash(registry, 'demo_msgs/msg/Inner')
    assert type_hash(registry, 'demo_msgs/msg/Outer') == outer

    # Default values and constants are not part of the hash.
    registry.register(parse_message('demo_msgs/msg/Inner', 'int32 X=3\nint32 x 7'), replace=True)
    assert type_hash(registry, 'demo_msgs/msg/Inner') == inner
    assert (
        type_description(registry, 'demo_msgs/msg/Inner')['type_description']['fields'][0][
            'default_value'
        ]
        == '7'
    )

    # A changed field type, also in a referenced type, changes the hash.
    registry.register(parse_message('demo_msgs/msg/Inner', 'int64 x'), replace=True)
    assert type_hash(registry, 'demo_msgs/msg/Inner') != inner
    assert type_hash(registry, 'demo_msgs/msg/Outer') != outer

    changes = ['string label', 'string<=5 name', 'string[] name', 'wstring name']
    seen = {type_hash(registry, 'demo_msgs/msg/Outer')}
    for index, text in enumerate(changes):
        name = f'demo_msgs/msg/Outer{index}'
        registry.register_text(name, f'demo_msgs/Inner inner\n{text}')
        seen.add(type_hash(registry, name))
    assert len(seen) == len(changes) + 1


def test_type_description_is_a_copy(jazzy: TypeRegistry) -> None:
    first = type_description(jazzy, 'std_msgs/msg/Header')
    first['type_description']['fields'].clear()
    again = type_description(jazzy, 'std_msgs/msg/Header')
    assert [f['name'] for f in again['type_description']['fields']] == ['stamp', 'frame_id']
    assert [d['type_name'] for d in again['referenced_type_descriptions']] == [
        'builtin_interfaces/msg/Time'
    ]


def test_empty_message_placeholder(jazzy: TypeRegistry) -> None:
    fields = type_description(jazzy, 'std_msgs/msg/Empty')['type_description']['fields']
    assert fields == [
        {
            'name': 'structure_needs_at_least_one_member',
            'type': {'type_id': 3, 'capacity': 0, 'string_capacity': 0, 'nested_type_name': ''},
            'default_value': '',
        }
    ]
