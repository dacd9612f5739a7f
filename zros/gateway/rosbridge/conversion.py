"""Messages as rosbridge shows them: the JSON and CBOR values of rosbridge_library's
``message_conversion`` and ``cbor_conversion`` for ROS 2, and back.

JSON (what rosbridge sends and takes):

* field names are the ROS names; nested messages are objects, sequences and arrays are lists;
* ``uint8[]``, ``char[]`` and ``uint8[N]`` are base64 strings (bounded ``uint8[<=N]`` stays a
  list of numbers, as in rosbridge); ``byte`` values are numbers;
* ``builtin_interfaces/Time`` and ``Duration`` are ``{"sec", "nanosec"}``;
* a NaN or infinite float is ``null`` (rosbridge writes ``NaN`` into fixed-size float arrays,
  which ``JSON.parse`` refuses; zros writes ``null`` there too);
* 64-bit integers are exact JSON numbers (JavaScript rounds those beyond 2^53, as with rosbridge).

Taking JSON: missing fields keep their defaults, an unknown field or a value of the wrong JSON
type is refused with rosbridge's wording, a number goes into a float field, base64 or a list
into a byte array, ``"now"`` or ``{"secs", "nsecs"}`` into a time, and a ``Header`` given
without a stamp gets the current time.

CBOR (``compression: cbor``): the same shapes, except that floats keep NaN, byte arrays are
byte strings and numeric arrays are typed arrays (RFC 8746 tags, little-endian).
"""

from __future__ import annotations

import base64
import binascii
import math
import secrets
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from zros.cdr.model import INTEGER_RANGES, Field, FieldType, Kind, MessageDef
from zros.cdr.naming import attribute_name
from zros.errors import ZrosError

if TYPE_CHECKING:
    from zros.cdr import JsonValue, Message, TypeRegistry
    from zros.gateway.common.json_types import OutObject

TIME_TYPES = ('builtin_interfaces/msg/Time', 'builtin_interfaces/msg/Duration')
HEADER = 'std_msgs/msg/Header'
#: RFC 8746 typed-array tags (little-endian), as rosbridge's cbor_conversion packs them
TYPED_ARRAY_TAGS = {
    'uint16': (69, '<u2'),
    'uint32': (70, '<u4'),
    'uint64': (71, '<u8'),
    'int8': (72, 'i1'),
    'int16': (77, '<i2'),
    'int32': (78, '<i4'),
    'int64': (79, '<i8'),
    'float32': (85, '<f4'),
    'float64': (86, '<f8'),
}
_BINARY = ('uint8', 'char')
#: base64 strings this long or longer may be spliced into the JSON text (``to_json``'s blobs)
BLOB_SIZE = 4096
_BLOB_NONCE = secrets.token_hex(16)  # no message can know it
_FLOATS = ('float32', 'float64')


class ConversionError(ZrosError):
    """A client's JSON does not make a message of the type (the text says why, in
    rosbridge's words)."""


def blob_mark(index: int) -> str:
    """What stands for the blob ``index`` in the values of :meth:`Values.to_json`."""
    return f'zros-blob-{_BLOB_NONCE}-{index}'


def short_name(type_name: str) -> str:
    """``pkg/msg/Name`` -> ``pkg/Name``, as rosbridge names types in its messages."""
    parts = type_name.split('/')
    return f'{parts[0]}/{parts[-1]}' if len(parts) == 3 else type_name


class Values:
    """Converts the messages of one registry to and from rosbridge values (definitions are
    looked up once per type)."""

    def __init__(self, registry: TypeRegistry, now: Callable[[], tuple[int, int]]) -> None:
        self.registry = registry
        self._now = now  #: (sec, nanosec) of the current ROS time
        self._definitions: dict[str, MessageDef] = {}

    def definition(self, type_name: str) -> MessageDef:
        """The definition of a message type (cached)."""
        found = self._definitions.get(type_name)
        if found is None:
            found = self._definitions[type_name] = self.registry.message_definition(type_name)
        return found

    # --- to the client -----------------------------------------------------------------------

    def to_json(self, message: Message, blobs: list[str] | None = None) -> OutObject:
        """The JSON values of a message, as rosbridge's ``extract_values``. With ``blobs``,
        base64 strings of :data:`BLOB_SIZE` characters or more go there, each replaced by
        :func:`blob_mark` of its index (JSON's encoder need not scan them: base64 has nothing
        to escape)."""
        return self._out(message, self.definition(message.__msgtype__), False, blobs)

    def to_cbor(self, message: Message) -> OutObject:
        """The CBOR values of a message (typed arrays as ``cbor2.CBORTag``)."""
        return self._out(message, self.definition(message.__msgtype__), True, None)

    def _out(
        self, message: Message, definition: MessageDef, cbor: bool, blobs: list[str] | None
    ) -> OutObject:
        values: dict[str, object] = {}
        for field in definition.fields:
            attribute = attribute_name(field.name)
            values[field.name] = self._out_field(message, attribute, field.type, cbor, blobs)
        return values

    def _out_field(
        self, message: Message, attribute: str, kind: FieldType, cbor: bool, blobs: list[str] | None
    ) -> object:
        # a field of a message whose class is built at run time: its value's type is kind's
        value = getattr(message, attribute)
        base = kind.base
        if kind.kind is Kind.SCALAR:
            if kind.is_nested:
                return self._out(value, self.definition(base), cbor, blobs)
            if base in _FLOATS:
                number = float(value)
                return number if cbor or math.isfinite(number) else None
            return value if kind.is_string else value.item() if hasattr(value, 'item') else value
        if kind.is_nested:
            definition = self.definition(base)
            return [self._out(item, definition, cbor, blobs) for item in value]
        if kind.is_string:
            return list(value)
        array = np.asarray(value)
        if base in _BINARY or (cbor and base == 'byte'):
            if cbor:
                return array.astype(np.uint8, copy=False).tobytes()
            if kind.kind is not Kind.BOUNDED:
                data = np.ascontiguousarray(array, np.uint8).data  # a buffer: no copy
                text = base64.b64encode(data).decode('ascii')
                if blobs is None or len(text) < BLOB_SIZE:
                    return text
                blobs.append(text)
                return blob_mark(len(blobs) - 1)
        if cbor and base in TYPED_ARRAY_TAGS:
            import cbor2  # noqa: PLC0415 (optional: the rosbridge extra)

            tag, dtype = TYPED_ARRAY_TAGS[base]
            return cbor2.CBORTag(tag, array.astype(dtype, copy=False).tobytes())
        if base in _FLOATS and not cbor and not np.isfinite(array).all():
            return [item if math.isfinite(item) else None for item in array.tolist()]
        return array.tolist()

    # --- from the client ---------------------------------------------------------------------

    def from_json(self, cls: type[Message], values: JsonValue) -> Message:
        """A message of ``cls`` from a client's values (a dict; missing fields keep their
        defaults); ConversionError says what is wrong."""
        root = short_name(cls.__msgtype__)
        if not isinstance(values, Mapping):
            raise ConversionError(
                f'Expected a JSON object for type {root} but received {_json_type(values)}'
            )
        fields = self._in(values, self.definition(cls.__msgtype__), root, [])
        try:
            return cls(**fields)
        except (TypeError, ValueError, OverflowError) as exc:
            raise ConversionError(f'{root}: {exc}') from None

    def _in(
        self, values: Mapping[str, JsonValue], definition: MessageDef, root: str, path: list[str]
    ) -> dict[str, object]:
        by_name = {field.name: field for field in definition.fields}
        fields: dict[str, object] = {}
        if definition.name == HEADER and 'stamp' not in values:
            sec, nanosec = self._now()
            fields['stamp'] = self.registry.get_class(TIME_TYPES[0])(sec=sec, nanosec=nanosec)
        for name, value in values.items():
            field = by_name.get(name)
            where = [*path, name]
            if field is None:
                raise ConversionError(
                    f'Message type {root} does not have a field {".".join(where)}'
                )
            fields[attribute_name(name)] = self._in_field(value, field, root, where)
        return fields

    def _mismatch(
        self, root: str, path: list[str], expected: str, value: object
    ) -> ConversionError:
        return ConversionError(
            f'{root} message requires a {expected} for field {".".join(path)}, '
            f'but got {_json_type(value)}'
        )

    def _in_field(self, value: JsonValue, field: Field, root: str, path: list[str]) -> object:
        kind = field.type
        if kind.kind is Kind.SCALAR:
            return self._in_scalar(value, kind, root, path)
        if kind.base in _BINARY and isinstance(value, str):
            try:
                data = base64.b64decode(value, validate=True)
            except (binascii.Error, ValueError):
                raise ConversionError(
                    f'{root}: field {".".join(path)} is not valid base64'
                ) from None
            return np.frombuffer(data, np.uint8)
        if not isinstance(value, list):
            raise self._mismatch(root, path, str(kind), value)
        if kind.kind is Kind.ARRAY and len(value) != kind.length:
            raise ConversionError(
                f'{root}: field {".".join(path)} holds exactly {kind.length} elements, '
                f'not {len(value)}'
            )
        element = kind.element
        if element.is_primitive:
            for item in value:
                self._check_primitive(item, element.base, root, path)
            return value
        return [self._in_scalar(item, element, root, path) for item in value]

    def _in_scalar(self, value: JsonValue, kind: FieldType, root: str, path: list[str]) -> object:
        base = kind.base
        if kind.is_primitive:
            return self._check_primitive(value, base, root, path)
        if kind.is_string:
            if not isinstance(value, str):
                raise self._mismatch(root, path, 'string', value)
            return value
        cls = self.registry.get_class(base)
        if base in TIME_TYPES:
            return cls(**self._time(value, base, root, path))
        if not isinstance(value, Mapping):
            raise self._mismatch(root, path, short_name(base), value)
        return cls(**self._in(value, self.definition(base), root, path))

    def _time(self, value: JsonValue, base: str, root: str, path: list[str]) -> dict[str, int]:
        if value == 'now' and base == TIME_TYPES[0]:
            sec, nanosec = self._now()
            return {'sec': sec, 'nanosec': nanosec}
        if not isinstance(value, Mapping):
            raise self._mismatch(root, path, short_name(base), value)
        time = {}
        for target, names in (('sec', ('sec', 'secs')), ('nanosec', ('nanosec', 'nsecs'))):
            for name in names:
                if name in value:
                    number = value[name]
                    if not isinstance(number, int) or isinstance(number, bool):
                        raise self._mismatch(root, [*path, name], 'int', number)
                    time[target] = number
                    break
        return time

    def _check_primitive(self, value: JsonValue, base: str, root: str, path: list[str]) -> object:
        if base in _FLOATS:
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise self._mismatch(root, path, base, value)
            return float(value)
        if base == 'bool':
            if not isinstance(value, bool):
                raise self._mismatch(root, path, base, value)
            return value
        if isinstance(value, bool) or not isinstance(value, int):
            raise self._mismatch(root, path, base, value)
        low, high = INTEGER_RANGES[base]
        if not low <= value <= high:
            raise ConversionError(
                f'{root}: {value} is out of the range of {base} [{low}, {high}] '
                f'(field {".".join(path)})'
            )
        return value


def _json_type(value: object) -> str:
    """The JSON kind of a value from ``json.loads``, with its article."""
    if value is None:
        return 'null'
    if isinstance(value, bool):
        return 'a boolean'
    if isinstance(value, (int, float)):
        return 'a number'
    if isinstance(value, str):
        return 'a string'
    if isinstance(value, list):
        return 'an array'
    return 'an object' if isinstance(value, Mapping) else type(value).__name__
