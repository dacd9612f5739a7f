"""Message classes for a recording: its embedded definitions first, the type registry second.

Each recording gets a registry of its own holding the definitions it embeds (MCAP schemas, the
db3 ``message_definitions`` table, ROS 1 connection headers), so a bag recorded with older or
custom types decodes as recorded. Embedded definitions can be wrong: every message is decoded
strictly (at most 3 trailing bytes), and when the embedded definition fails, the definition the
registry knows is tried before giving up.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from zros.bag.errors import BagError
from zros.bag.source import Connection, RawMessage
from zros.cdr import CdrError, Message, TypeRegistry, UnknownTypeError, default_registry
from zros.cdr.message import decode
from zros.cdr.model import split_type_name

_log = logging.getLogger('zros.bag')
_EVENT = '_Event'
_IDL_RULE = '=' * 80 + '\n'


@dataclass
class _Choice:
    """The classes that may decode one connection's messages, the one that works first."""

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
    ) -> None:
        self.path = path
        self.fallback = registry or default_registry()
        self.registry = TypeRegistry(self.fallback.distro)
        self._embedded: set[int] = set()
        self._choices: dict[int, _Choice] = {}
        for connection in connections:
            if self._register(connection):
                self._embedded.add(connection.id)

    def _register(self, connection: Connection) -> bool:
        """Register a connection's embedded definition; False when it has none that parses."""
        name, text, form = connection.type_name, connection.definition, connection.definition_format
        if not form:
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
        from rosbags.typesys import get_types_from_idl

        from zros.cdr.registry import _from_rosbags

        parts = [text]
        if text.startswith(_IDL_RULE + 'IDL: '):
            parts = [part.split('\n', 1)[1] for part in text.split(_IDL_RULE)[1:]]
        for part in parts:
            for name, fielddefs in get_types_from_idl(part).items():
                self.registry.register(_from_rosbags(name, fielddefs))

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
        if not classes:
            reason = '; '.join(failures)
            raise BagError(
                self.path,
                f'cannot decode topic {connection.topic}: type {name} has no definition in the '
                f'recording and none zros knows ({reason})',
            )
        choice = _Choice(classes)
        self._choices[connection.id] = choice
        return choice

    def message_class(self, connection: Connection) -> type[Message]:
        """The class messages of a connection decode to (the embedded one until it fails)."""
        choice = self._choice(connection)
        return choice.classes[choice.current][0]

    def decode(self, message: RawMessage) -> Message:
        """Decode one raw message; raises :class:`BagError` when no definition fits its data."""
        choice = self._choice(message.connection)
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
        raise BagError(
            self.path,
            f'cannot decode the message of {message.connection.topic} at {message.timestamp} '
            f'as {message.connection.type_name}: ' + '; '.join(problems),
        )


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
