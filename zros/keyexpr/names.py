"""ROS 2 names: validation, expansion of relative and ``~`` names, and remapping.

The rules are those of rcl and rmw (validate_topic_name, validate_full_topic_name,
validate_node_name, validate_namespace), so a name zros accepts is one ROS 2 accepts.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from zros.keyexpr.errors import InvalidNameError

#: rmw's limit for fully qualified topic names (leaves room for the DDS prefixes)
MAX_NAME_LENGTH = 247
MAX_NODE_NAME_LENGTH = 255


def _isalnum(char: str) -> bool:
    return char.isascii() and char.isalnum()


def validate_node_name(name: str) -> None:
    """Raise InvalidNameError unless ``name`` is a valid ROS 2 node name."""
    if not name:
        raise InvalidNameError('node name', name, 0, 'it must not be empty')
    for index, char in enumerate(name):
        if not (_isalnum(char) or char == '_'):
            raise InvalidNameError(
                'node name', name, index, 'only letters, digits and "_" are allowed'
            )
    if name[0].isdigit():
        raise InvalidNameError('node name', name, 0, 'it must not start with a digit')
    if len(name) > MAX_NODE_NAME_LENGTH:
        raise InvalidNameError(
            'node name', name, MAX_NODE_NAME_LENGTH, f'longer than {MAX_NODE_NAME_LENGTH}'
        )


def validate_full_name(name: str, kind: str = 'topic name') -> None:
    """Raise InvalidNameError unless ``name`` is a valid fully qualified name (``/a/b``)."""
    if not name:
        raise InvalidNameError(kind, name, 0, 'it must not be empty')
    if name[0] != '/':
        raise InvalidNameError(kind, name, 0, 'a fully qualified name starts with "/"')
    if name[-1] == '/' and not (name == '/' and kind == 'namespace'):
        raise InvalidNameError(kind, name, len(name) - 1, 'it must not end with "/"')
    for index, char in enumerate(name):
        if not (_isalnum(char) or char in '_/'):
            raise InvalidNameError(
                kind, name, index, 'only letters, digits, "_" and "/" are allowed'
            )
    for index in range(len(name) - 1):
        if name[index] == '/':
            if name[index + 1] == '/':
                raise InvalidNameError(kind, name, index + 1, 'it must not contain "//"')
            if name[index + 1].isdigit():
                raise InvalidNameError(
                    kind, name, index + 1, 'a name token must not start with a digit'
                )
    if len(name) > MAX_NAME_LENGTH:
        raise InvalidNameError(
            kind, name, MAX_NAME_LENGTH, f'longer than {MAX_NAME_LENGTH} characters (ROS 2 limit)'
        )


def validate_namespace(namespace: str) -> None:
    """Raise InvalidNameError unless ``namespace`` is a valid node namespace (``/`` or ``/a/b``)."""
    validate_full_name(namespace, 'namespace')


def validate_name(name: str, kind: str = 'topic name') -> None:
    """Raise InvalidNameError unless ``name`` is a valid (possibly relative or ``~``) name."""
    if not name:
        raise InvalidNameError(kind, name, 0, 'it must not be empty')
    if name[0].isdigit():
        raise InvalidNameError(kind, name, 0, 'a name token must not start with a digit')
    if name[-1] == '/':
        raise InvalidNameError(kind, name, len(name) - 1, 'it must not end with "/"')
    for index, char in enumerate(name):
        if _isalnum(char) or char in '_/':
            continue
        if char == '~':
            if index != 0:
                raise InvalidNameError(kind, name, index, '"~" is only allowed first')
            continue
        if char in '{}':
            raise InvalidNameError(
                kind, name, index, 'substitutions "{...}" are not supported by zros'
            )
        raise InvalidNameError(
            kind, name, index, 'only letters, digits, "_", "/" and a leading "~" are allowed'
        )
    if name.startswith('~') and len(name) > 1 and name[1] != '/':
        raise InvalidNameError(kind, name, 1, '"~" must be followed by "/"')


def join(namespace: str, name: str) -> str:
    """``namespace`` + ``/`` + ``name`` without a doubled slash."""
    return namespace.rstrip('/') + '/' + name


def expand(name: str, node_name: str, namespace: str, kind: str = 'topic name') -> str:
    """The fully qualified form of a topic or service name, as rcl expands it.

    ``/x`` stays, ``x`` becomes ``<namespace>/x``, ``~`` is the node's own name
    ``<namespace>/<node>`` and ``~/x`` is ``<namespace>/<node>/x``.
    """
    validate_name(name, kind)
    if name.startswith('/'):
        full = name
    elif name == '~':
        full = join(namespace, node_name)
    elif name.startswith('~/'):
        full = join(join(namespace, node_name), name[2:])
    else:
        full = join(namespace, name)
    validate_full_name(full, kind)
    return full


@dataclass(frozen=True)
class Remapping:
    """Name remapping rules (``--ros-args -r from:=to``), optionally for one node only."""

    rules: tuple[tuple[str | None, str, str], ...] = ()  #: (node or None, from, to)
    node_name: str | None = None  #: ``__node:=`` override
    namespace: str | None = None  #: ``__ns:=`` override
    unused: tuple[str, ...] = field(default=(), compare=False)

    @classmethod
    def parse(cls, rules: Iterable[str] | Mapping[str, str]) -> Remapping:
        """Parse ``from:=to`` strings (or a dict ``{from: to}``); ``node:from:=to`` is per node."""
        items = (
            [f'{key}:={value}' for key, value in rules.items()]
            if isinstance(rules, Mapping)
            else list(rules)
        )
        parsed: list[tuple[str | None, str, str]] = []
        node_name = namespace = None
        for item in items:
            source, separator, target = item.partition(':=')
            if not separator or not source or not target:
                raise ValueError(f'a remapping is written "from:=to", got {item!r}')
            node: str | None = None
            if ':' in source:
                node, source = source.split(':', 1)
            if source == '__node':
                validate_node_name(target)
                node_name = target
            elif source == '__ns':
                validate_namespace(target)
                namespace = target
            else:
                validate_name(source, 'remapping source')
                validate_name(target, 'remapping target')
                parsed.append((node, source, target))
        return cls(tuple(parsed), node_name, namespace)

    def apply(self, full_name: str, node_name: str, namespace: str) -> str:
        """The name ``full_name`` is remapped to for this node (itself when no rule matches)."""
        for node, source, target in self.rules:
            if node is not None and node != node_name:
                continue
            if expand(source, node_name, namespace) == full_name:
                return expand(target, node_name, namespace)
        return full_name


@dataclass(frozen=True)
class RosArgs:
    """What a ``--ros-args ... [--]`` section of a command line holds."""

    remapping: Remapping = field(default_factory=Remapping)
    parameters: dict[str, str] = field(default_factory=dict)  #: ``-p name:=value`` (text)
    params_files: tuple[str, ...] = ()  #: ``--params-file FILE``
    log_level: str | None = None  #: ``--log-level LEVEL``
    rest: tuple[str, ...] = ()  #: the arguments outside ``--ros-args``


def parse_ros_args(argv: Iterable[str]) -> RosArgs:
    """Split ``--ros-args ... [--]`` out of a command line, as rcl reads it.

    Understands ``-r``/``--remap from:=to``, ``-p``/``--param name:=value``,
    ``--params-file FILE`` and ``--log-level LEVEL``; other arguments are kept in ``rest``.
    """
    remaps: list[str] = []
    parameters: dict[str, str] = {}
    files: list[str] = []
    log_level = None
    rest: list[str] = []
    args = list(argv)
    index = 0
    in_ros_args = False

    def value_of(flag: str) -> str:
        if index + 1 >= len(args):
            raise ValueError(f'{flag} needs a value')
        return args[index + 1]

    while index < len(args):
        arg = args[index]
        if arg == '--ros-args':
            in_ros_args = True
        elif in_ros_args and arg == '--':
            in_ros_args = False
        elif in_ros_args and arg in ('-r', '--remap'):
            if index + 1 >= len(args):
                raise ValueError(f'{arg} needs a "from:=to" argument')
            remaps.append(args[index + 1])
            index += 1
        elif in_ros_args and arg.startswith('--remap='):
            remaps.append(arg.split('=', 1)[1])
        elif in_ros_args and arg in ('-p', '--param'):
            name, separator, value = value_of(arg).partition(':=')
            if not separator or not name:
                raise ValueError(f'a parameter is written "name:=value", got {args[index + 1]!r}')
            parameters[name] = value
            index += 1
        elif in_ros_args and arg == '--params-file':
            files.append(value_of(arg))
            index += 1
        elif in_ros_args and arg == '--log-level':
            log_level = value_of(arg)
            index += 1
        else:
            rest.append(arg)
        index += 1
    return RosArgs(Remapping.parse(remaps), parameters, tuple(files), log_level, tuple(rest))
