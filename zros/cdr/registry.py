"""Resolve ROS type names to definitions and generated classes.

Sources, first match wins: definitions registered at run time, folders on ``ZROS_INTERFACE_PATH``,
``share/<pkg>`` folders under ``AMENT_PREFIX_PATH``, the interface files zros ships (the demo's
``rosR_demos``), the few services and actions zros defines, and the rosbags typestore of the
selected ROS distro.
"""

from __future__ import annotations

import difflib
import os
import sys
import threading
from collections.abc import Iterable, Mapping, Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import TYPE_CHECKING

from zros.cdr.builtin import BUILTIN_ORIGIN, SHIPPED_PACKAGES, builtin_definition, builtin_names
from zros.cdr.classes import Decoder, build_message_class, compiled_decoder
from zros.cdr.errors import UnknownTypeError
from zros.cdr.interfaces import ActionType, ServiceType
from zros.cdr.layout import LayoutCache
from zros.cdr.message import Message, decode
from zros.cdr.model import (
    ActionDef,
    Definition,
    MessageDef,
    ServiceDef,
    action_parts,
    service_messages,
    split_type_name,
    type_name_candidates,
)
from zros.cdr.parser import parse_definition, parse_message_bundle
from zros.cdr.typestore import TYPESTORE_ORIGIN, from_rosbags

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

#: Distros zros knows, and whether their services define an ``_Event`` message.
DISTROS: dict[str, bool] = {'humble': False, 'iron': True, 'jazzy': True, 'kilted': True}
DEFAULT_DISTRO = 'jazzy'

_EXTENSIONS = {'msg': '.msg', 'srv': '.srv', 'action': '.action'}
_ACTION_SUFFIXES = (
    '_SendGoal_Request',
    '_SendGoal_Response',
    '_SendGoal_Event',
    '_GetResult_Request',
    '_GetResult_Response',
    '_GetResult_Event',
    '_FeedbackMessage',
    '_SendGoal',
    '_GetResult',
    '_Goal',
    '_Result',
    '_Feedback',
)
_SERVICE_SUFFIXES = ('_Request', '_Response', '_Event')


def _of(type_name: str, name: str) -> bool:
    """Whether ``type_name`` is ``name`` or one of its parts (``name_Request``...)."""
    return type_name == name or type_name.startswith(name + '_')


def _env_paths(variable: str) -> list[Path]:
    return [Path(p) for p in os.environ.get(variable, '').split(os.pathsep) if p]


class TypeRegistry:
    """Definitions and generated classes for one ROS distro.

    ``paths`` replaces ``ZROS_INTERFACE_PATH``; ``ament=False`` ignores ``AMENT_PREFIX_PATH``.
    Each entry of either may be a folder of packages (``<dir>/<pkg>/msg/X.msg``), a package
    folder (``<dir>/msg/X.msg``), an install prefix (``<dir>/share/<pkg>/msg/X.msg``) or, on
    ``ZROS_INTERFACE_PATH``, a workspace's ``install`` (``<dir>/<pkg>/share/<pkg>/msg/X.msg``).
    """

    def __init__(
        self,
        distro: str | None = None,
        paths: Sequence[str | os.PathLike[str]] | None = None,
        ament: bool = True,
    ) -> None:
        chosen = (distro or os.environ.get('ZROS_DISTRO') or DEFAULT_DISTRO).lower()
        if chosen not in DISTROS:
            raise ValueError(
                f'unknown ROS distro {chosen!r}; zros knows {", ".join(sorted(DISTROS))}'
            )
        self.distro = chosen
        self.has_service_events = DISTROS[chosen]
        self._paths = (
            [Path(p) for p in paths] if paths is not None else _env_paths('ZROS_INTERFACE_PATH')
        )
        self._ament = _env_paths('AMENT_PREFIX_PATH') if ament else []
        self._registered: dict[str, Definition] = {}
        self._definitions: dict[str, Definition] = {}
        self._messages: dict[str, MessageDef] = {}
        self._classes: dict[str, type[Message]] = {}
        self._types: dict[str, ServiceType | ActionType] = {}
        #: compiled decoders by every spelling asked for (``zros.cdr.decode`` reads them)
        self._decoders: dict[str, Decoder] = {}
        self._store: Typestore | None = None
        self._lock = threading.RLock()
        #: layout facts of this registry's message types
        self.layout = LayoutCache(self.message_definition)

    @property
    def lock(self) -> AbstractContextManager[bool]:
        """The re-entrant lock that guards this registry; its classes compile codecs under it."""
        return self._lock

    # --- sources ---------------------------------------------------------------------------

    @property
    def typestore(self) -> Typestore:
        """The rosbags typestore of this distro (loaded on first use)."""
        if self._store is None:
            from rosbags.typesys import Stores, get_typestore  # noqa: PLC0415 (lazy: rosbags, import time)

            self._store = get_typestore(Stores[f'ROS2_{self.distro.upper()}'])
        return self._store

    def _candidate_files(self, name: str) -> list[Path]:
        package, kind, short = split_type_name(name)
        filename = short + _EXTENSIONS[kind]
        files = []
        for entry in self._paths:
            files.append(entry / package / kind / filename)
            files.append(entry / 'share' / package / kind / filename)
            # a colcon workspace's install folder (one prefix per package)
            files.append(entry / package / 'share' / package / kind / filename)
            if entry.name == package:
                files.append(entry / kind / filename)
        files += [prefix / 'share' / package / kind / filename for prefix in self._ament]
        if package in SHIPPED_PACKAGES:
            files.append(SHIPPED_PACKAGES[package] / kind / filename)
        return files

    def text_files(self, name: str) -> list[Path]:
        """Existing files that may hold the text of ``name``: this registry's sources, then the
        ``share`` folder of ROS 2 wheels installed in this Python environment (their files have
        the comments the typestores drop; ``interface show`` prints them)."""
        package, kind, short = split_type_name(name)
        files = self._candidate_files(name)
        wheels = Path(sys.prefix) / 'share'
        if (wheels / 'ament_index').is_dir():
            files.append(wheels / package / kind / (short + _EXTENSIONS[kind]))
        return [path for path in files if path.is_file()]

    def _load(self, name: str) -> Definition | None:
        if name in self._registered:
            return self._registered[name]
        for path in self._candidate_files(name):
            if path.is_file():
                return parse_definition(name, path.read_text(encoding='utf-8'), str(path))
        found = builtin_definition(name)
        if found is not None:
            return found
        if split_type_name(name)[1] == 'msg':
            fielddefs = self.typestore.fielddefs.get(name)
            if fielddefs is not None:
                return from_rosbags(name, fielddefs)
        return None

    def _searched(self, name: str) -> list[str]:
        places = [f'definitions registered at run time ({len(self._registered)})']
        if self._paths:
            places += [f'ZROS_INTERFACE_PATH entry {p}' for p in self._paths]
        else:
            places.append('ZROS_INTERFACE_PATH (not set)')
        if self._ament:
            places += [f'AMENT_PREFIX_PATH entry {p}/share' for p in self._ament]
        else:
            places.append('AMENT_PREFIX_PATH (not set or ignored)')
        places.append(
            f'zros built-in services and actions, and packages {", ".join(SHIPPED_PACKAGES)}'
        )
        places.append(
            f'rosbags typestore ros2_{self.distro} ({len(self.typestore.fielddefs)} messages)'
        )
        return places

    def _unknown(self, name: str) -> UnknownTypeError:
        package, kind, short = split_type_name(name)
        close = difflib.get_close_matches(name, self.names(), n=3)
        hint = f'Add {package}/{kind}/{short}{_EXTENSIONS[kind]} to a folder on ZROS_INTERFACE_PATH'
        hint += ' or register its text with zros.cdr.register_type().'
        if close:
            hint = f'Did you mean {" or ".join(close)}? ' + hint
        return UnknownTypeError(name, self._searched(name), hint)

    # --- definitions -----------------------------------------------------------------------

    def register(self, definition: Definition, replace: bool = False) -> None:
        """Make a definition known under its name (it takes precedence over every other source).

        A definition that differs from one registered before, or from one a class was already
        generated from, raises ValueError unless ``replace`` is true (the old classes are then
        dropped). A definition merely loaded from a file or the typestore is replaced silently.
        """
        with self._lock:
            name = definition.name
            split_type_name(name)
            known = self._registered.get(name) or self._definitions.get(name)
            if known is not None and known != definition:
                if self._in_use(name) and not replace:
                    raise ValueError(
                        f'{name} is already defined differently (from '
                        f'{known.origin or "unknown"}); pass replace=True to override it'
                    )
                self._forget(name)
            self._registered[name] = definition

    def _in_use(self, name: str) -> bool:
        return name in self._registered or any(
            key == name or key.startswith(name + '_') for key in self._classes
        )

    def register_text(self, name: str, text: str, origin: str = '<registered text>') -> Definition:
        """Parse and register .msg, .srv or .action text (the kind comes from ``name``)."""
        definition = parse_definition(name, text, origin)
        self.register(definition)
        return definition

    def register_bundle(
        self,
        name: str,
        text: str,
        origin: str = '<registered bundle>',
        override_dependencies: bool = False,
    ) -> None:
        """Register a message with its dependencies in the concatenated bag format.

        Dependencies already known are left alone unless ``override_dependencies`` is true (a
        bag's own definitions describe its data); the main message is always registered.
        """
        for index, message in enumerate(parse_message_bundle(name, text, origin)):
            if index == 0 or override_dependencies or self.find(message.name) is None:
                self.register(message)

    def _forget(self, name: str) -> None:
        self._decoders.clear()  # spellings of the name are not known here; rebuilt on use
        self._definitions.pop(name, None)
        for cache in (self._messages, self._classes, self._types):
            for key in [k for k in cache if _of(k, name)]:
                del cache[key]
        # other spellings (``pkg/Name``) of the forgotten classes
        for key in [k for k, c in self._classes.items() if _of(c.__msgtype__, name)]:
            del self._classes[key]

    def find(self, name: str) -> Definition | None:
        """The definition of a full type name (also an action's SendGoal/GetResult), or None."""
        with self._lock:
            if name in self._definitions:
                return self._definitions[name]
            found = self._load(name)
            if found is None:
                parent = self.parent(name)
                if parent is not None and self.find(parent) is not None:
                    return self._definitions.get(name)
                return None
            self._definitions[name] = found
            self._add_derived(found)
            return found

    def definition(self, name: str) -> Definition:
        """The definition of a type; accepts every spelling of ``type_name_candidates``."""
        for candidate in type_name_candidates(name):
            found = self.find(candidate)
            if found is not None:
                return found
        raise self._unknown(type_name_candidates(name)[0])

    def _add_derived(self, definition: Definition) -> None:
        if isinstance(definition, MessageDef):
            self._messages[definition.name] = definition
        elif isinstance(definition, ServiceDef):
            for message in service_messages(definition, self.has_service_events):
                self._messages[message.name] = message
        else:
            messages, services = action_parts(definition)
            for message in messages:
                self._messages[message.name] = message
            for service in services:
                self._definitions[service.name] = service
                self._add_derived(service)

    def standard(self, name: str) -> bool:
        """Whether ``name`` is one of the distro's typestore or zros's built-in types (every
        ROS 2 install has it), not one found in files or registered at run time."""
        found = self._definitions.get(name)
        if found is not None and found.origin in (BUILTIN_ORIGIN, TYPESTORE_ORIGIN):
            return True  # without loading the typestore
        return name in builtin_names() or name in self.typestore.fielddefs

    def parent(self, name: str) -> str | None:
        """The service or action a part's name belongs to (``pkg/action/A_SendGoal``:
        ``pkg/action/A``), or None."""
        package, kind, short = split_type_name(name)
        suffixes = _ACTION_SUFFIXES if kind == 'action' else _SERVICE_SUFFIXES
        for suffix in suffixes:
            if short.endswith(suffix) and len(short) > len(suffix):
                return f'{package}/{kind}/{short[: -len(suffix)]}'
        return None

    def message_definition(self, name: str) -> MessageDef:
        """The definition of a message type, including the messages of services and actions."""
        with self._lock:
            candidates = type_name_candidates(name)
            for candidate in candidates:
                if candidate in self._messages:
                    return self._messages[candidate]
                found = self.find(candidate)
                if isinstance(found, MessageDef):
                    return found
                parent = self.parent(candidate)
                found_parent = parent is not None and self.find(parent) is not None
                if found_parent and candidate in self._messages:
                    return self._messages[candidate]
            raise self._unknown(candidates[0])

    def names(self) -> list[str]:
        """Every full type name this registry can resolve without further files, sorted."""
        names = set(self.typestore.fielddefs) | set(builtin_names()) | set(self._registered)
        roots = [*self._paths, *(entry / 'share' for entry in [*self._paths, *self._ament])]
        for root in roots:
            names.update(_scan(root))
        for package, folder in SHIPPED_PACKAGES.items():
            names.update(f'{package}/{name.split("/", 1)[1]}' for name in _scan(folder))
        return sorted(names)

    # --- classes ---------------------------------------------------------------------------

    def get_class(self, name: str) -> type[Message]:
        """The generated class of a message type."""
        with self._lock:
            cls = self._classes.get(name)
            if cls is not None:
                return cls
            definition = self.message_definition(name)
            cls = self._classes.get(definition.name)
            if cls is None:
                cls = build_message_class(self, definition, restore_message)
                self._classes[definition.name] = cls
            self._classes[name] = cls
            return cls

    def decoder(self, name: str) -> Decoder:
        """The compiled decoder (``decode(buf, strict) -> message``) of a message type, by any
        spelling of its name; cached, so repeated look-ups cost one dict access."""
        found = self._decoders.get(name)
        if found is None:
            found = compiled_decoder(self.get_class(name))
            with self._lock:
                self._decoders[name] = found
        return found

    @property
    def decoders(self) -> Mapping[str, Decoder]:
        """The decoders :meth:`decoder` returned so far, by the spelling asked for."""
        return self._decoders

    def get_service(self, name: str) -> ServiceType:
        """The service type (``.Request``, ``.Response``, ``.Event``) of a service name."""
        found = self.definition(name)
        if not isinstance(found, ServiceDef):
            raise TypeError(f'{found.name} is not a service type')
        with self._lock:
            known = self._types.get(found.name)
            if not isinstance(known, ServiceType):
                known = ServiceType(self, found)
                self._types[found.name] = known
            return known

    def get_action(self, name: str) -> ActionType:
        """The action type (``.Goal``, ``.Result``, ``.Feedback``...) of an action name."""
        found = self.definition(name)
        if not isinstance(found, ActionDef):
            raise TypeError(f'{found.name} is not an action type')
        with self._lock:
            known = self._types.get(found.name)
            if not isinstance(known, ActionType):
                known = ActionType(self, found)
                self._types[found.name] = known
            return known

    def get_type(self, name: str | type[Message]) -> type[Message] | ServiceType | ActionType:
        """A message class, service type or action type, by any accepted spelling of its name."""
        if isinstance(name, type):
            return name
        candidates = type_name_candidates(name)
        for candidate in candidates:
            found = self.find(candidate)
            if isinstance(found, ServiceDef):
                return self.get_service(candidate)
            if isinstance(found, ActionDef):
                return self.get_action(candidate)
            if isinstance(found, MessageDef) or self.parent(candidate) is not None:
                try:
                    return self.get_class(candidate)
                except UnknownTypeError:
                    continue
        raise self._unknown(candidates[0])


def _scan(root: Path) -> Iterable[str]:
    if not root.is_dir():
        return
    packages = [root] if any((root / kind).is_dir() for kind in _EXTENSIONS) else root.iterdir()
    for package in packages:
        for kind, extension in _EXTENSIONS.items():
            folder = package / kind
            if folder.is_dir():
                for file in folder.glob('*' + extension):
                    yield f'{package.name}/{kind}/{file.stem}'


_default: TypeRegistry | None = None
_default_lock = threading.Lock()
#: the default registry's decoders by name (empty until it exists): ``zros.cdr.decode`` reads
#: it without taking a lock
default_decoders: Mapping[str, Decoder] = {}


def default_registry() -> TypeRegistry:
    """The process-wide registry (distro from ``ZROS_DISTRO``, default Jazzy)."""
    global _default, default_decoders  # noqa: PLW0603
    with _default_lock:
        if _default is None:
            _default = TypeRegistry()
            default_decoders = _default.decoders
        return _default


def set_default_registry(registry: TypeRegistry) -> None:
    """Replace the process-wide registry, e.g. to select another distro."""
    global _default, default_decoders  # noqa: PLW0603
    with _default_lock:
        _default = registry
        default_decoders = registry.decoders


def registry_of(cls: type[Message]) -> TypeRegistry:
    """The registry that built a message class (a bag's own, or the default one...)."""
    registry = getattr(cls, '_registry', None)
    if not isinstance(registry, TypeRegistry):
        raise TypeError(f'{cls.__name__} was not built by a TypeRegistry')
    return registry


def restore_message(type_name: str, data: bytes) -> Message:
    """A message from its type name and CDR bytes, as unpickling rebuilds it (the default
    registry's class: a process that unpickles knows nothing of the registry that pickled)."""
    return decode(default_registry().get_class(type_name), data)
