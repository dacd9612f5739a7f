"""The interface model: message, service and action definitions as plain immutable values.

Type names are always kept in their full form ``pkg/msg/Name``, ``pkg/srv/Name`` or
``pkg/action/Name``. Derived types (``S_Request``, ``A_SendGoal_Request``...) are built here too,
so every layer above sees one message definition per CDR type.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass, field

from zros.cdr.errors import TypeNameError

#: The bytes a decoder reads: CDR from the network, a file or the user.
Buffer = bytes | bytearray | memoryview
#: A JSON value: nested dicts and lists whose shape the reader checks (isinstance) where it reads.
JsonValue = None | bool | int | float | str | list['JsonValue'] | dict[str, 'JsonValue']

#: Wire size (and CDR alignment) of every primitive type.
PRIMITIVE_SIZES: dict[str, int] = {
    'bool': 1,
    'byte': 1,
    'char': 1,
    'int8': 1,
    'uint8': 1,
    'int16': 2,
    'uint16': 2,
    'int32': 4,
    'uint32': 4,
    'int64': 8,
    'uint64': 8,
    'float32': 4,
    'float64': 8,
}

#: Inclusive value range of the integer primitives.
INTEGER_RANGES: dict[str, tuple[int, int]] = {
    'byte': (0, 255),
    'char': (0, 255),
    'int8': (-(2**7), 2**7 - 1),
    'uint8': (0, 2**8 - 1),
    'int16': (-(2**15), 2**15 - 1),
    'uint16': (0, 2**16 - 1),
    'int32': (-(2**31), 2**31 - 1),
    'uint32': (0, 2**32 - 1),
    'int64': (-(2**63), 2**63 - 1),
    'uint64': (0, 2**64 - 1),
}

STRING_TYPES = ('string', 'wstring')
INTERFACE_KINDS = ('msg', 'srv', 'action')

_NAME_PART = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')


class Kind(enum.Enum):
    """How many values a field holds."""

    SCALAR = 'scalar'
    ARRAY = 'array'  #: fixed size ``T[N]``
    BOUNDED = 'bounded'  #: bounded sequence ``T[<=N]``
    SEQUENCE = 'sequence'  #: unbounded sequence ``T[]``


@dataclass(frozen=True)
class FieldType:
    """The type of one field: a base type plus an optional array or sequence shape."""

    base: str  #: primitive name, ``string``, ``wstring``, or a full message name
    kind: Kind = Kind.SCALAR
    length: int = 0  #: the N of ``T[N]`` and ``T[<=N]``, else 0
    string_bound: int = 0  #: the N of ``string<=N``, else 0

    @property
    def is_primitive(self) -> bool:
        return self.base in PRIMITIVE_SIZES

    @property
    def is_string(self) -> bool:
        return self.base in STRING_TYPES

    @property
    def is_nested(self) -> bool:
        return not (self.is_primitive or self.is_string)

    @property
    def is_scalar(self) -> bool:
        return self.kind is Kind.SCALAR

    @property
    def element(self) -> FieldType:
        """The type of one element (the type itself for a scalar)."""
        if self.kind is Kind.SCALAR:
            return self
        return FieldType(self.base, Kind.SCALAR, 0, self.string_bound)

    def base_text(self) -> str:
        """The base type as written in .msg files, with a string bound."""
        if self.string_bound:
            return f'{self.base}<={self.string_bound}'
        return self.base

    def __str__(self) -> str:
        text = self.base_text()
        if self.kind is Kind.ARRAY:
            return f'{text}[{self.length}]'
        if self.kind is Kind.BOUNDED:
            return f'{text}[<={self.length}]'
        if self.kind is Kind.SEQUENCE:
            return f'{text}[]'
        return text


Value = bool | int | float | str
DefaultValue = Value | tuple[Value, ...]


@dataclass(frozen=True)
class Field:
    """One field of a message, with its parsed default value (None when it has none)."""

    name: str
    type: FieldType
    default: DefaultValue | None = None


@dataclass(frozen=True)
class Constant:
    """A named constant of a message; its type is a primitive or string scalar."""

    name: str
    type: FieldType
    value: Value


@dataclass(frozen=True)
class MessageDef:
    """A message type: ordered fields and constants."""

    name: str
    fields: tuple[Field, ...]
    constants: tuple[Constant, ...] = ()
    origin: str = field(default='', compare=False)
    #: the text it was parsed from, comments included ('' when it came from a typestore)
    source: str = field(default='', compare=False, repr=False)

    def nested_types(self) -> list[str]:
        """Names of the message types the fields refer to, in field order, without repeats."""
        seen: dict[str, None] = {}
        for f in self.fields:
            if f.type.is_nested:
                seen.setdefault(f.type.base, None)
        return list(seen)


@dataclass(frozen=True)
class ServiceDef:
    """A service type: its request and response messages."""

    name: str
    request: MessageDef
    response: MessageDef
    origin: str = field(default='', compare=False)
    #: the .srv text it was parsed from, comments included
    source: str = field(default='', compare=False, repr=False)


@dataclass(frozen=True)
class ActionDef:
    """An action type: its goal, result and feedback messages."""

    name: str
    goal: MessageDef
    result: MessageDef
    feedback: MessageDef
    origin: str = field(default='', compare=False)
    #: the .action text it was parsed from, comments included
    source: str = field(default='', compare=False, repr=False)


Definition = MessageDef | ServiceDef | ActionDef


def split_type_name(name: str) -> tuple[str, str, str]:
    """Split a full type name into (package, kind, short name), validating it."""
    parts = name.split('/')
    if (
        len(parts) != 3
        or parts[1] not in INTERFACE_KINDS
        or not _NAME_PART.match(parts[0])
        or not _NAME_PART.match(parts[2])
    ):
        raise TypeNameError(
            f'{name!r} is not a full ROS type name; expected "pkg/msg/Name", '
            '"pkg/srv/Name" or "pkg/action/Name"'
        )
    return parts[0], parts[1], parts[2]


def type_name_candidates(name: str) -> list[str]:
    """The full names a user-supplied type name may mean, most likely first.

    Accepts ``pkg/msg/Name``, the ROS 1 style ``pkg/Name`` (message, then service, then action),
    and the IDL/DDS spellings ``pkg::msg::Name`` and ``pkg::msg::dds_::Name_``.
    """
    text = name.strip()
    if '::' in text:
        parts = [p for p in text.split('::') if p != 'dds_']
        if len(parts) == 3 and parts[2].endswith('_'):
            parts[2] = parts[2][:-1]
        text = '/'.join(parts)
    parts = text.split('/')
    if len(parts) == 3:
        split_type_name(text)
        return [text]
    if len(parts) == 2 and _NAME_PART.match(parts[0]) and _NAME_PART.match(parts[1]):
        return [f'{parts[0]}/{kind}/{parts[1]}' for kind in INTERFACE_KINDS]
    raise TypeNameError(
        f'{name!r} is not a ROS type name; expected "pkg/msg/Name" (or "pkg/Name", '
        '"pkg/srv/Name", "pkg/action/Name")'
    )


# --- derived types of services and actions ------------------------------------------------

_UUID = FieldType('unique_identifier_msgs/msg/UUID')
_TIME = FieldType('builtin_interfaces/msg/Time')
_EVENT_INFO = FieldType('service_msgs/msg/ServiceEventInfo')


def _renamed(msg: MessageDef, name: str) -> MessageDef:
    return MessageDef(name, msg.fields, msg.constants, msg.origin)


def service_messages(srv: ServiceDef, with_event: bool = True) -> list[MessageDef]:
    """The messages a service defines: ``S_Request``, ``S_Response`` and (Iron+) ``S_Event``."""
    request = _renamed(srv.request, srv.name + '_Request')
    response = _renamed(srv.response, srv.name + '_Response')
    result = [request, response]
    if with_event:
        result.append(
            MessageDef(
                srv.name + '_Event',
                (
                    Field('info', _EVENT_INFO),
                    Field('request', FieldType(request.name, Kind.BOUNDED, 1)),
                    Field('response', FieldType(response.name, Kind.BOUNDED, 1)),
                ),
                origin=srv.origin,
            )
        )
    return result


def action_parts(act: ActionDef) -> tuple[list[MessageDef], list[ServiceDef]]:
    """The messages and services an action defines.

    Messages: ``A_Goal``, ``A_Result``, ``A_Feedback``, ``A_FeedbackMessage``; services:
    ``A_SendGoal`` (goal id + goal -> accepted + stamp) and ``A_GetResult`` (goal id -> status
    + result). The services' own messages come from :func:`service_messages`.
    """
    goal = _renamed(act.goal, act.name + '_Goal')
    result = _renamed(act.result, act.name + '_Result')
    feedback = _renamed(act.feedback, act.name + '_Feedback')
    feedback_message = MessageDef(
        act.name + '_FeedbackMessage',
        (Field('goal_id', _UUID), Field('feedback', FieldType(feedback.name))),
        origin=act.origin,
    )
    send_goal = ServiceDef(
        act.name + '_SendGoal',
        MessageDef('', (Field('goal_id', _UUID), Field('goal', FieldType(goal.name)))),
        MessageDef('', (Field('accepted', FieldType('bool')), Field('stamp', _TIME))),
        origin=act.origin,
    )
    get_result = ServiceDef(
        act.name + '_GetResult',
        MessageDef('', (Field('goal_id', _UUID),)),
        MessageDef(
            '', (Field('status', FieldType('int8')), Field('result', FieldType(result.name)))
        ),
        origin=act.origin,
    )
    return [goal, result, feedback, feedback_message], [send_goal, get_result]
