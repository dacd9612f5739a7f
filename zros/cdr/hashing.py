"""RIHS01 type hashes (REP 2011) of messages, services and actions.

A type hash is the SHA-256 of a canonical JSON rendering of the type's ``TypeDescription``: the
type's own field list plus, sorted by name, the field lists of every type it refers to, directly
or not. Services and actions are described as structures whose fields are their derived types
(request, response and event messages; goal, result, feedback, the two services and the feedback
message). The result matches what rosidl_generator_type_description computes at build time.
"""

from __future__ import annotations

import copy
import hashlib
import json
import threading
import weakref
from typing import TypedDict

from zros.cdr.errors import UnknownTypeError
from zros.cdr.model import (
    ActionDef,
    DefaultValue,
    Definition,
    Field,
    FieldType,
    Kind,
    MessageDef,
    ServiceDef,
    action_parts,
    service_messages,
    type_name_candidates,
)
from zros.cdr.parser import parse_message
from zros.cdr.registry import TypeRegistry
from zros.cdr.typestore import PLACEHOLDER_FIELD

RIHS01_PREFIX = 'RIHS01_'

#: type_description_interfaces/msg/FieldType ids of the scalar base types. A .msg ``char`` is an
#: IDL ``uint8``, so it has the UINT8 id, not FIELD_TYPE_CHAR (13).
_BASE_IDS: dict[str, int] = {
    'int8': 2,
    'uint8': 3,
    'char': 3,
    'int16': 4,
    'uint16': 5,
    'int32': 6,
    'uint32': 7,
    'int64': 8,
    'uint64': 9,
    'float32': 10,
    'float64': 11,
    'bool': 15,
    'byte': 16,
    'string': 17,
    'wstring': 18,
}
_NESTED_ID = 1
_BOUNDED_STRING_IDS = {'string': 21, 'wstring': 22}
_KIND_OFFSETS = {Kind.SCALAR: 0, Kind.ARRAY: 48, Kind.BOUNDED: 96, Kind.SEQUENCE: 144}

#: Used when the registry's distro has no service_msgs (Humble): the Iron+ definition.
_EVENT_INFO_NAME = 'service_msgs/msg/ServiceEventInfo'
_EVENT_INFO_TEXT = """
uint8 REQUEST_SENT = 0
uint8 REQUEST_RECEIVED = 1
uint8 RESPONSE_SENT = 2
uint8 RESPONSE_RECEIVED = 3
uint8 event_type
builtin_interfaces/Time stamp
char[16] client_gid
int64 sequence_number
"""

_PLACEHOLDER = Field(PLACEHOLDER_FIELD, FieldType('uint8'))


class FieldTypeDescription(TypedDict):
    """A ``type_description_interfaces/msg/FieldType`` as a dict."""

    type_id: int
    capacity: int
    string_capacity: int
    nested_type_name: str


class FieldDescription(TypedDict, total=False):
    """A ``type_description_interfaces/msg/Field`` as a dict (no ``default_value`` when
    hashed)."""

    name: str
    type: FieldTypeDescription
    default_value: str


class IndividualTypeDescription(TypedDict):
    """A ``type_description_interfaces/msg/IndividualTypeDescription`` as a dict."""

    type_name: str
    fields: list[FieldDescription]


class TypeDescription(TypedDict):
    """A ``type_description_interfaces/msg/TypeDescription`` as a dict."""

    type_description: IndividualTypeDescription
    referenced_type_descriptions: list[IndividualTypeDescription]


Description = IndividualTypeDescription


class _Entry:
    """A cached full description, with the definitions it was built from."""

    def __init__(self, description: TypeDescription, sources: dict[str, Definition]) -> None:
        self.description = description
        self.sources = sources
        self.hash: str | None = None


_caches: weakref.WeakKeyDictionary[TypeRegistry, dict[str, _Entry]] = weakref.WeakKeyDictionary()
_lock = threading.Lock()


# --- resolving names ------------------------------------------------------------------------


def _derived_event(registry: TypeRegistry, name: str) -> MessageDef | None:
    """The ``S_Event`` message of a service, also for distros whose registry has none."""
    if not name.endswith('_Event'):
        return None
    parent = registry.find(name[: -len('_Event')])
    if not isinstance(parent, ServiceDef):
        return None
    return service_messages(parent, with_event=True)[2]


def _resolve(registry: TypeRegistry, name: str) -> Definition:
    """The definition of a full type name: a message (also derived), service or action."""
    found = registry.find(name)
    if found is not None:
        return found
    try:
        return registry.message_definition(name)
    except UnknownTypeError:
        event = _derived_event(registry, name)
        if event is not None:
            return event
        if name == _EVENT_INFO_NAME:
            return parse_message(name, _EVENT_INFO_TEXT, 'zros.cdr.hashing fallback')
        raise


def _canonical_name(registry: TypeRegistry, name: str) -> str:
    """The full name of a possibly abbreviated type name (``pkg/Name``...)."""
    candidates = type_name_candidates(name)
    if len(candidates) == 1:
        return candidates[0]
    for candidate in candidates:
        try:
            _resolve(registry, candidate)
        except UnknownTypeError:
            continue
        return candidate
    return candidates[0]


# --- individual descriptions ----------------------------------------------------------------


def _default_text(value: DefaultValue | None) -> str:
    """The default value as rosidl writes it (Python ``str`` of the IDL annotation value)."""
    if value is None:
        return ''
    return str(value)


def _field_type(ftype: FieldType) -> FieldTypeDescription:
    if ftype.is_nested:
        type_id = _NESTED_ID
    elif ftype.string_bound:
        type_id = _BOUNDED_STRING_IDS[ftype.base]
    else:
        type_id = _BASE_IDS[ftype.base]
    return {
        'type_id': type_id + _KIND_OFFSETS[ftype.kind],
        'capacity': ftype.length if ftype.kind in (Kind.ARRAY, Kind.BOUNDED) else 0,
        'string_capacity': ftype.string_bound,
        'nested_type_name': ftype.base if ftype.is_nested else '',
    }


def _field(name: str, ftype: FieldType, default: DefaultValue | None = None) -> FieldDescription:
    return {'name': name, 'type': _field_type(ftype), 'default_value': _default_text(default)}


def _individual(name: str, definition: Definition) -> Description:
    """The IndividualTypeDescription of one type, under ``name``."""
    if isinstance(definition, ServiceDef):
        fields = [
            _field(field, FieldType(f'{name}_{suffix}'))
            for field, suffix in (
                ('request_message', 'Request'),
                ('response_message', 'Response'),
                ('event_message', 'Event'),
            )
        ]
    elif isinstance(definition, ActionDef):
        fields = [
            _field(field, FieldType(f'{name}_{suffix}'))
            for field, suffix in (
                ('goal', 'Goal'),
                ('result', 'Result'),
                ('feedback', 'Feedback'),
                ('send_goal_service', 'SendGoal'),
                ('get_result_service', 'GetResult'),
                ('feedback_message', 'FeedbackMessage'),
            )
        ]
    else:
        members = definition.fields or (_PLACEHOLDER,)
        fields = [_field(f.name, f.type, f.default) for f in members]
    return {'type_name': name, 'fields': fields}


def _local_parts(definition: Definition) -> dict[str, Definition]:
    """The derived types a service or action defines itself, by name."""
    parts: dict[str, Definition] = {}
    if isinstance(definition, ServiceDef):
        for message in service_messages(definition, with_event=True):
            parts[message.name] = message
    elif isinstance(definition, ActionDef):
        messages, services = action_parts(definition)
        for message in messages:
            parts[message.name] = message
        for service in services:
            parts[service.name] = service
            parts.update(_local_parts(service))
    return parts


def _build(registry: TypeRegistry, name: str) -> _Entry:
    """Collect the type and everything it refers to, as rosidl's full TypeDescription."""
    top = _resolve(registry, name)
    sources: dict[str, Definition] = {name: top}
    local = _local_parts(top)
    descriptions: dict[str, Description] = {}
    pending = [name]
    while pending:
        current = pending.pop()
        if current in descriptions:
            continue
        definition = sources.get(current) or local.get(current)
        if definition is None:
            definition = _resolve(registry, current)
            sources[current] = definition
        description = _individual(current, definition)
        descriptions[current] = description
        for field in description['fields']:
            nested = field['type']['nested_type_name']
            if nested and nested not in descriptions:
                pending.append(nested)
    referenced = sorted(n for n in descriptions if n != name)
    full: TypeDescription = {
        'type_description': descriptions[name],
        'referenced_type_descriptions': [descriptions[n] for n in referenced],
    }
    return _Entry(full, sources)


def _still_valid(registry: TypeRegistry, entry: _Entry) -> bool:
    """Whether every definition the entry was built from still resolves to the same thing."""
    for name, definition in entry.sources.items():
        try:
            now = _resolve(registry, name)
        except UnknownTypeError:
            return False
        if now is not definition and now != definition:
            return False
    return True


def _entry(registry: TypeRegistry, name: str) -> _Entry:
    full_name = _canonical_name(registry, name)
    with _lock:
        cache = _caches.get(registry)
        if cache is None:
            cache = {}
            _caches[registry] = cache
        entry = cache.get(full_name)
    if entry is not None and _still_valid(registry, entry):
        return entry
    entry = _build(registry, full_name)
    with _lock:
        cache[full_name] = entry
    return entry


# --- public API -----------------------------------------------------------------------------


def type_description(registry: TypeRegistry, name: str) -> TypeDescription:
    """The full TypeDescription of a type as rosidl builds it, default values included."""
    return copy.deepcopy(_entry(registry, name).description)


def hash_description(description: TypeDescription) -> str:
    """The RIHS01 hash of a full TypeDescription (its default values are ignored)."""
    stripped = {
        'type_description': _without_defaults(description['type_description']),
        'referenced_type_descriptions': [
            _without_defaults(d) for d in description['referenced_type_descriptions']
        ],
    }
    text = json.dumps(stripped, ensure_ascii=True, separators=(', ', ': '), sort_keys=False)
    return RIHS01_PREFIX + hashlib.sha256(text.encode('utf-8')).hexdigest()


def _without_defaults(individual: Description) -> Description:
    return {
        'type_name': individual['type_name'],
        'fields': [{'name': f['name'], 'type': f['type']} for f in individual['fields']],
    }


def type_hash(registry: TypeRegistry, name: str) -> str:
    """The ``RIHS01_<64 hex>`` hash of a message, service or action (derived ones too)."""
    entry = _entry(registry, name)
    if entry.hash is None:
        entry.hash = hash_description(entry.description)
    return entry.hash


# --- back from descriptions -----------------------------------------------------------------

_IDS_TO_BASE = {type_id: base for base, type_id in _BASE_IDS.items() if base != 'char'}
_IDS_TO_BASE.update({type_id: base for base, type_id in _BOUNDED_STRING_IDS.items()})


def message_text(individual: Description, with_defaults: bool = True) -> str:
    """The .msg text of one IndividualTypeDescription (a ROS node's answer to
    ``GetTypeDescription``): its fields, with their defaults; descriptions carry no constants
    and no comments. ValueError for a field type id that is not a message field."""
    lines = []
    fields = individual['fields']
    if [f['name'] for f in fields] == [PLACEHOLDER_FIELD]:
        fields = []
    for f in fields:
        ftype = f['type']
        offset = max(o for o in _KIND_OFFSETS.values() if o <= ftype['type_id'])
        kind = next(k for k, o in _KIND_OFFSETS.items() if o == offset)
        base_id = ftype['type_id'] - offset
        if base_id == _NESTED_ID:
            package, _, short = ftype['nested_type_name'].split('/')
            text = f'{package}/{short}'
        elif base_id in _IDS_TO_BASE:
            text = _IDS_TO_BASE[base_id]
            if ftype['string_capacity']:
                text += f'<={ftype["string_capacity"]}'
        else:
            raise ValueError(f'field {f["name"]!r} has the unknown type id {ftype["type_id"]}')
        if kind is Kind.ARRAY:
            text += f'[{ftype["capacity"]}]'
        elif kind is Kind.BOUNDED:
            text += f'[<={ftype["capacity"]}]'
        elif kind is Kind.SEQUENCE:
            text += '[]'
        line = f'{text} {f["name"]}'
        default = f.get('default_value', '')
        if with_defaults and default:
            # rosidl writes Python's str of the value: tuples for arrays, True/False for bools
            if default.startswith('(') and default.endswith(')'):
                default = '[' + default[1:-1].rstrip(',') + ']'
            line += ' ' + {'True': 'true', 'False': 'false'}.get(default, default)
        lines.append(line)
    return ''.join(line + '\n' for line in lines)
