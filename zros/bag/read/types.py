"""Message classes for a recording: its embedded definitions first, the type registry second.

Each recording gets a registry of its own holding the definitions it embeds (MCAP schemas, the
db3 ``message_definitions`` table, ROS 1 connection headers), so a bag recorded with older or
custom types decodes as recorded. Embedded definitions can be wrong: every message is decoded
strictly (at most 3 trailing bytes), and when the embedded definition fails, the definition the
registry knows is tried before giving up.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from zros.bag.errors import BagError
from zros.bag.read.damage import Damage, Skipped
from zros.bag.read.source import Connection, RawMessage
from zros.cdr import CdrError, Message, TypeRegistry, UnknownTypeError, default_registry
from zros.cdr.message import decode
from zros.cdr.model import split_type_name
from zros.cdr.typestore import from_rosbags

if TYPE_CHECKING:
    from typing_extensions import Self


_log = logging.getLogger('zros.bag')
_EVENT = '_Event'
_IDL_RULE = '=' * 80 + '\n'


class UndecodedMessage(Message):
    """A message of a type with no definition in the recording nor anywhere zros looks: its
    CDR bytes as recorded (4-byte header included) in ``data``, its type in ``__msgtype__``.

    Reading a bag gives these for such a topic, and decoded messages for every other one. With
    the definition at hand, ``zros.cdr.decode(type_name, message.data)`` decodes one.
    """

    __slots__ = ('data',)
    __msgtype__ = ''
    __hash__ = None  # as every message

    def __init__(self, data: bytes) -> None:
        object.__setattr__(self, 'data', data)

    @classmethod
    def of_type(cls, type_name: str) -> type[UndecodedMessage]:
        """The class for undecoded messages of ``type_name`` (one per name)."""
        known = _UNDECODED.get(type_name)
        if known is None:
            known = _UNDECODED[type_name] = type(
                'UndecodedMessage', (cls,), {'__slots__': (), '__msgtype__': type_name}
            )
        return known

    def copy(self) -> Self:
        """Another message with the same bytes."""
        return type(self)(self.data)

    def to_dict(self) -> dict[str, object]:
        """Refused: without a definition there are no fields."""
        raise TypeError(
            f'{self.__msgtype__} has no definition: no fields, only its CDR bytes in .data'
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, UndecodedMessage):
            return NotImplemented
        return self.__msgtype__ == other.__msgtype__ and self.data == other.data

    def __repr__(self) -> str:
        return f'UndecodedMessage({self.__msgtype__}, {len(self.data)} bytes)'

    def __reduce__(self) -> tuple[Callable[[str, bytes], UndecodedMessage], tuple[str, bytes]]:
        return (_undecoded, (self.__msgtype__, self.data))


_UNDECODED: dict[str, type[UndecodedMessage]] = {}


def _undecoded(type_name: str, data: bytes) -> UndecodedMessage:
    return UndecodedMessage.of_type(type_name)(data)


def how_to_define(type_name: str) -> str:
    """The one thing to do so zros knows a type: where its file goes, or the call."""
    try:
        package, kind, short = split_type_name(type_name)
    except ValueError as exc:  # a damaged or foreign name: no file or call can define it
        return f'the name is not one a definition can have ({exc})'
    return (
        f'to decode it, run with ZROS_INTERFACE_PATH=<a folder holding '
        f'{package}/{kind}/{short}.{kind}>, or call '
        f"zros.cdr.register_type('{type_name}', <its .{kind} text>) before reading"
    )


@dataclass
class _Choice:
    """The classes that may decode one connection's messages, the one that works first.
    No class: the type has no definition anywhere, its messages stay undecoded."""

    classes: list[tuple[type[Message], str]]  #: (class, where its definition came from)
    current: int = 0
    problems: list[str] = field(default_factory=list)


class BagTypes:
    """Decodes the raw messages of one recording into zros message classes."""

    def __init__(
        self,
        path: Path,
        connections: list[Connection],
        registry: TypeRegistry | None = None,
        damage: Damage | None = None,
        locate: Callable[[RawMessage], tuple[Path, int | None, int | None]] | None = None,
    ) -> None:
        self.path = path
        #: where messages that no definition decodes are reported (:meth:`decode_or_skip`)
        self.damage = damage or Damage()
        #: a message's (file, byte offset, row), for the report
        self.locate = locate or (lambda message: (path, None, None))
        self.fallback = registry or default_registry()
        self.registry = TypeRegistry(self.fallback.distro)
        self._embedded: set[int] = set()
        self._choices: dict[int, _Choice] = {}
        self._warned: set[str] = set()  #: types whose messages were said to stay undecoded
        #: connections whose embedded definition is empty: an unknown type recorded with an
        #: empty schema, unless its messages are as short as an empty message's
        self._empty: set[int] = set()
        for connection in connections:
            if self._register(connection):
                self._embedded.add(connection.id)

    def _register(self, connection: Connection) -> bool:
        """Register a connection's embedded definition; False when it has none that parses."""
        name, text, form = connection.type_name, connection.definition, connection.definition_format
        if form not in _READ_FORMATS:  # none, or an encoding no ROS reader reads
            return False
        origin = f'{self.path} ({connection.topic})'
        try:
            package, kind, short = split_type_name(name)
            if form == 'ros2idl':
                self._register_idl(text)
            elif kind == 'srv' and short.endswith(_EVENT) and '---' in text:
                # rosbag2 stores the .srv text of the service for its event topic
                self.registry.register_text(f'{package}/srv/{short[: -len(_EVENT)]}', text, origin)
            elif text.strip():
                self.registry.register_bundle(name, text, origin, override_dependencies=True)
            else:
                self.registry.register_text(name, '', origin)
                self._empty.add(connection.id)
        except (ValueError, CdrError) as exc:
            # a syntax error, or a second definition of a type that differs from the first
            _log.warning(
                '%s: ignoring the embedded definition of %s on %s: %s',
                self.path,
                name,
                connection.topic,
                exc,
            )
            return False
        return True

    def _register_idl(self, text: str) -> None:
        from rosbags.typesys import get_types_from_idl  # noqa: PLC0415 (lazy: rosbags, import time)

        parts = [text]
        if text.startswith(_IDL_RULE + 'IDL: '):
            parts = [part.split('\n', 1)[1] for part in text.split(_IDL_RULE)[1:]]
        for part in parts:
            for name, fielddefs in get_types_from_idl(part).items():
                self.registry.register(from_rosbags(name, fielddefs))

    def _choice(self, connection: Connection) -> _Choice:
        known = self._choices.get(connection.id)
        if known is not None:
            return known
        classes: list[tuple[type[Message], str]] = []
        failures: list[str] = []
        name = connection.type_name
        if connection.id in self._embedded:
            try:
                classes.append((self.registry.get_class(name), 'the definition in the recording'))
            except (UnknownTypeError, ValueError, CdrError) as exc:
                failures.append(f'its embedded definition is incomplete: {exc}')
        try:
            standard = self.fallback.get_class(name)
        except (UnknownTypeError, ValueError, CdrError) as exc:
            failures.append(str(exc))
        else:
            if not classes or _definitions_differ(self.registry, self.fallback, name):
                classes.append((standard, 'the definition of the type registry'))
        choice = _Choice(classes, problems=failures)
        self._choices[connection.id] = choice
        return choice

    def decodable(self, connection: Connection) -> bool:
        """Whether a connection's type has a definition (embedded or known to zros)."""
        return bool(self._choice(connection).classes)

    def message_class(self, connection: Connection) -> type[Message]:
        """The class messages of a connection decode to (the embedded one until it fails).

        Raises :class:`BagError` for a type with no definition anywhere.
        """
        choice = self._choice(connection)
        if not choice.classes:
            name = connection.type_name
            raise BagError(
                self.path,
                f'topic {connection.topic} has type {name}, which has {_nowhere(connection)}, '
                f'so no fields (Bag.messages gives its messages undecoded); '
                f'{how_to_define(name)}',
            )
        return choice.classes[choice.current][0]

    def decode(self, message: RawMessage) -> Message:
        """Decode one raw message; raises :class:`BagError` when no definition fits its data.

        A type with no definition anywhere gives an :class:`UndecodedMessage` (one warning per
        type).
        """
        choice = self._choice(message.connection)
        if not choice.classes:
            return self._undecoded(message, _nowhere(message.connection))
        cls = choice.classes[choice.current][0]
        try:
            return decode(cls, message.data, True)
        except CdrError as first:
            problems = [f'{choice.classes[choice.current][1]}: {first}']
        for index, (other, origin) in enumerate(choice.classes):
            if index == choice.current:
                continue
            try:
                decoded = decode(other, message.data, True)
            except CdrError as exc:
                problems.append(f'{origin}: {exc}')
                continue
            _log.warning(
                '%s: %s on %s does not match its data (%s); using %s',
                self.path,
                choice.classes[choice.current][1],
                message.connection.topic,
                problems[0],
                origin,
            )
            choice.current = index
            return decoded
        if message.connection.id in self._empty:  # longer than an empty message: no definition
            return self._undecoded(
                message, 'an empty definition in the recording, but longer messages than it makes'
            )
        raise BagError(
            self.path,
            f'cannot decode the message of {message.connection.topic} at {message.timestamp} '
            f'as {message.connection.type_name}: ' + '; '.join(problems),
        )

    def decode_or_skip(self, message: RawMessage) -> Message | None:
        """:meth:`decode`, but a message no definition decodes (damaged data) is reported to
        ``damage`` and skipped (None); in strict mode that raises :class:`BagError`."""
        try:
            return self.decode(message)
        except BagError as exc:
            file, offset, row = self.locate(message)
            self.damage.report(
                [Skipped(file, offset, row, message.connection.topic, 1, exc.reason)]
            )
            return None

    def _undecoded(self, message: RawMessage, found: str) -> Message:
        name = message.connection.type_name
        if name not in self._warned:
            self._warned.add(name)
            _log.warning(
                '%s: type %s (topic %s) has %s: its messages come back undecoded, as '
                'zros.bag.UndecodedMessage with the CDR bytes in .data; %s',
                self.path,
                name,
                message.connection.topic,
                found,
                how_to_define(name),
            )
        data = message.data
        return UndecodedMessage.of_type(name)(data if isinstance(data, bytes) else bytes(data))


#: the definition formats zros reads (MCAP schema encodings, rosbag2's type encodings)
_READ_FORMATS = ('ros2msg', 'ros2idl')


def _nowhere(connection: Connection) -> str:
    """What a connection whose type has no definition has instead, as a phrase."""
    form = connection.definition_format
    if form and form not in _READ_FORMATS:
        return (
            f'its definition in schema encoding {form!r}, which zros does not read (it reads '
            f'{" and ".join(_READ_FORMATS)}), and none zros knows'
        )
    return 'no definition in the recording and none zros knows'


def _definitions_differ(bag: TypeRegistry, standard: TypeRegistry, name: str) -> bool:
    """Whether a nested type of ``name`` differs between the two registries."""
    seen: set[str] = set()
    todo = [name]
    while todo:
        current = todo.pop()
        if current in seen:
            continue
        seen.add(current)
        try:
            mine = bag.message_definition(current)
            theirs = standard.message_definition(current)
        except (UnknownTypeError, ValueError):
            return True
        if mine != theirs:
            return True
        todo.extend(mine.nested_types())
    return False
