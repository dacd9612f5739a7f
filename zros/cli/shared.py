"""What the ``zros`` subcommands share: connection options, the command node, values, exits.

Exit codes: 0 success, 1 a failure the message explains, 2 a usage error (argparse, a setting
that cannot work such as a malformed endpoint, or a field name or value a message type refuses),
130 interrupted before finishing, 141 the reader of the output went away (``| head``; no
traceback). Continuous commands (echo, hz...) stopped with Ctrl-C exit 0.
"""

from __future__ import annotations

import argparse
import difflib
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import TYPE_CHECKING, cast

from zros.version import counted as counted  # noqa: PLC0414 (the commands' import of it)
from zros.wire.schemes import DEFAULT_WIRE, SCHEMES, WireOption, chosen_wire, scheme_settings

# commands import zros's heavy parts (numpy, Zenoh) inside the functions that use them:
# `zros --help` loads none of them
if TYPE_CHECKING:
    from typing_extensions import Unpack

    from zros.cdr.message import Message
    from zros.node import Node
    from zros.node.settings import NodeKeywords, NodeOptions


DISCOVERY = 2.0  #: seconds a one-shot command gives the graph to show itself


class CommandError(Exception):
    """A failure to report in one line, exit code 1."""

    exit_code = 1


class UsageError(CommandError):
    """A mistake in what was typed (a field name, a value), exit code 2 as argparse's own."""

    exit_code = 2


def add_connection_options(parser: argparse.ArgumentParser) -> None:
    """``--connect``, ``--mode``, ``--wire`` and each scheme's settings (``--bridge-namespace``,
    ``--domain-id``; environment: ZROS_CONNECT...)."""
    group = parser.add_argument_group('connection')
    group.add_argument(
        '--connect',
        action='append',
        metavar='ENDPOINT',
        help='router or bridge to reach, e.g. tcp/robot:7447 or robot:7447 (default: '
        '$ZROS_CONNECT, else tcp/127.0.0.1:7447)',
    )
    group.add_argument('--mode', choices=('client', 'peer'), help='Zenoh mode (default client)')
    schemes = ', '.join(f'{name}: {scheme.help}' for name, scheme in SCHEMES.items())
    group.add_argument(
        '--wire',
        choices=tuple(SCHEMES),
        help=f'the wire scheme: {schemes} (default: $ZROS_WIRE, else {DEFAULT_WIRE})',
    )
    for scheme in SCHEMES.values():
        for setting in scheme.settings:
            group.add_argument(
                setting.flag, metavar=setting.metavar, type=setting.parse,
                help=f'--wire {scheme.name}: {setting.help}',
            )  # fmt: skip


def add_verbs(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], name: str, help_line: str
) -> argparse._SubParsersAction[argparse.ArgumentParser]:
    """Command ``name``, made of verbs (``zros topic``): where to add them (:func:`add_verb`)."""
    parser = commands.add_parser(name, help=help_line)
    return parser.add_subparsers(dest='verb', metavar='VERB', required=True)


def add_verb(
    verbs: argparse._SubParsersAction[argparse.ArgumentParser],
    name: str,
    help_text: str,
    run: Callable[[argparse.Namespace], int],
) -> argparse.ArgumentParser:
    """The parser of a command's verb (``zros topic echo``): ``help_text`` as its help and
    description, ``run`` as what runs it, and the connection options."""
    parser = verbs.add_parser(name, help=help_text, description=help_text)
    parser.set_defaults(run=run)
    add_connection_options(parser)
    return parser


#: seconds ``--wait`` alone waits for a name to appear
WAIT = 10.0


def add_wait_option(parser: argparse.ArgumentParser, kind: str) -> None:
    """``--wait [S]``: wait up to S seconds (default 10) for the ``kind`` to appear; without
    it, a name the graph does not show fails at once with the closest known names."""
    parser.add_argument(
        '--wait', type=float, nargs='?', const=WAIT, metavar='S',
        help=f'wait up to S seconds (default {WAIT:g}) for the {kind} to appear (without '
        '--wait: a name not on the network fails at once, with the closest ones)',
    )  # fmt: skip


def wire_settings(args: argparse.Namespace) -> dict[str, WireOption]:
    """The wire settings given on the command line (``--bridge-namespace``...), by keyword;
    a usage error for a setting of another scheme than the one chosen."""
    given: dict[str, WireOption] = {
        setting.keyword: getattr(args, setting.keyword, None)
        for scheme in SCHEMES.values()
        for setting in scheme.settings
    }
    chosen = getattr(args, 'wire', None)
    try:
        wire = chosen_wire(chosen)  # --wire's choices are checked already: ZROS_WIRE is not
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    for scheme in SCHEMES.values():  # named as typed, not as Node's keywords
        for setting in scheme.settings:
            if given[setting.keyword] is not None and not SCHEMES[wire].takes(setting.keyword):
                using = f'--wire {wire}' if chosen else f'ZROS_WIRE={wire}'
                if not chosen and 'ZROS_WIRE' not in os.environ:
                    using = f'the default wire, {wire}'
                raise UsageError(f'{setting.flag} is for --wire {scheme.name}, not {using}')
    return scheme_settings(wire, given)


def node_name(args: argparse.Namespace) -> str:
    """The name of a command's own node: ``zros_<command>_<verb>_<pid>``, e.g.
    ``zros_topic_hz_4242`` (``zros_graph_4242`` for a command without verbs)."""
    parts = [getattr(args, 'command', None) or 'cli', getattr(args, 'verb', None), os.getpid()]
    return '_'.join(['zros', *(str(p).replace('-', '_') for p in parts if p)])


def open_node(args: argparse.Namespace, **options: Unpack[NodeOptions]) -> Node:
    """The command's node (:func:`node_name`): no /rosout, no parameter services, its own
    session (unless ``transport=`` is given); its publishers and subscriptions show on the
    graph as any node's."""
    from zros.node import Node

    # the wire's keywords (bridge_namespace, domain_id), checked by scheme_settings
    settings = cast('NodeKeywords', wire_settings(args))
    if getattr(args, 'wire', None):
        settings['wire'] = args.wire
    if 'transport' not in options:  # else the session is made already
        settings['connect'] = getattr(args, 'connect', None)
        if getattr(args, 'mode', None):
            settings['mode'] = args.mode
    options.setdefault('enable_rosout', False)
    options.setdefault('start_parameter_services', False)
    keywords: NodeKeywords = {**settings, **options}
    return Node(node_name(args), **keywords)


def names_on_graph(node: Node, kind: str) -> dict[str, list[str]]:
    """The ``'topics'``, ``'services'`` or ``'actions'`` on the network and their types, after
    asking the network for the whole graph."""
    node.graph.refresh(DISCOVERY)
    names: dict[str, list[str]] = getattr(node.graph, kind)(node.scheme.namespace)
    return names


def add_listing_options(parser: argparse.ArgumentParser, kind: str, hidden: bool = True) -> None:
    """ros2's ``-c/--count-<kind>`` and (``hidden``) ``--include-hidden-<kind>`` of a verb
    listing the ``kind`` (topics, services...); :func:`listed` applies them."""
    parser.add_argument(
        '-c',
        f'--count-{kind}',
        dest='count',
        action='store_true',
        help=f'only the number of {kind}',
    )
    if hidden:
        parser.add_argument(
            f'--include-hidden-{kind}', dest='include_hidden', action='store_true',
            help=f'{kind} with a name part starting with _ too (hidden by default, as ros2)',
        )  # fmt: skip


def listed(args: argparse.Namespace, names: dict[str, list[str]]) -> dict[str, list[str]]:
    """``names`` without the hidden ones unless ``--include-hidden-...``."""
    from zros.pubsub.taps import is_hidden

    if getattr(args, 'include_hidden', True):
        return names
    return {name: types for name, types in names.items() if not is_hidden(name)}


def list_names(args: argparse.Namespace, kind: str) -> int:
    """``zros <kind> list [-t] [-c]``."""
    with open_node(args) as node:
        names = listed(args, names_on_graph(node, kind))
        if args.count:
            out(str(len(names)))
            return 0
        for name, types in names.items():
            out(f'{name} [{", ".join(types)}]' if args.show_types else name)
    return 0


def print_types(args: argparse.Namespace, kind: str, name: str) -> int:
    """``zros service|action type NAME``: the types announced for ``name``."""
    with open_node(args) as node:
        resolved = node.resolve_name(name)
        types = names_on_graph(node, kind).get(resolved)
        if not types:
            raise CommandError(f'{kind[:-1]} {resolved} does not appear on the network')
        for type_name in types:
            out(type_name)
    return 0


def find_names(args: argparse.Namespace, kind: str, type_name: str) -> int:
    """``zros <kind> find TYPE [-c]``: the names announced with that type."""
    with open_node(args) as node:
        found = [n for n, types in listed(args, names_on_graph(node, kind)).items()
                 if type_name in types]  # fmt: skip
        for line in [str(len(found))] if args.count else found:
            out(line)
    return 0


def parse_values(text: str | None) -> dict[str, object]:
    """Message fields from YAML text, as ``ros2 topic pub`` takes them: ``"{data: hi}"``."""
    if not text:
        return {}
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        values = YAML(typ='safe', pure=True).load(text)
    except YAMLError as exc:
        problem = getattr(exc, 'problem', None)
        mark = getattr(exc, 'problem_mark', None)
        if problem and mark is not None:  # one line: what, and where
            where = f'column {mark.column + 1}' if '\n' not in text else f'line {mark.line + 1}'
            raise UsageError(f'the values are not valid YAML: {problem} ({where})') from None
        raise UsageError(f'the values are not valid YAML: {exc}') from None
    if values is None:
        return {}
    if not isinstance(values, dict):
        raise UsageError(f'the values must be a YAML mapping like "{{data: 1}}", not {text!r}')
    return values


def message_class(type_name: str) -> type[Message]:
    """The message class of a type name (``std_msgs/msg/String`` or ``std_msgs/String``)."""
    from zros.cdr import default_registry
    from zros.cdr.interfaces import ActionType, ServiceType

    found = default_registry().get_type(type_name)
    if isinstance(found, (ServiceType, ActionType)):
        raise CommandError(f'{type_name} is not a message type')
    return found


def unknown_name(kind: str, name: str, known: Iterable[str], listing: str) -> CommandError:
    """The error for a ``kind`` (topic, service...) the graph does not show: the closest known
    names ("did you mean /chatter?"), else the command ``listing`` them."""
    matches = difflib.get_close_matches(name, list(known), n=3, cutoff=0.6)
    hint = f'did you mean {" or ".join(matches)}?' if matches else f'{listing} shows them'
    return CommandError(f'{kind} {name} does not appear on the network: {hint}')


def require_on_graph(node: Node, kind: str, name: str) -> None:
    """Fail with the closest names unless ``name`` is among the graph's ``'topics'``,
    ``'services'``, ``'actions'`` or ``'nodes'``, once the graph has answered (it normally
    does at once): a mistyped name fails now, not after the whole wait."""
    node.graph.refresh(DISCOVERY)
    if kind == 'nodes':
        known: Iterable[str] = [n for n in node.graph.nodes() if n != node.fully_qualified_name]
    else:
        known = names_on_graph(node, kind)
    if name not in known:
        raise unknown_name(kind[:-1], name, known, f'zros {kind[:-1]} list')


def require_advertised_type(node: Node, kind: str, name: str, type_name: str) -> None:
    """Fail unless the graph's ``'topics'``, ``'services'`` or ``'actions'`` advertise
    ``name`` with ``type_name`` (or not at all): a type that differs fails before anything is
    sent or printed, naming the one the graph shows."""
    node.graph.refresh(DISCOVERY)
    types = names_on_graph(node, kind).get(node.resolve_name(name), [])
    if types and type_name not in types:
        raise CommandError(f'{node.resolve_name(name)} carries {", ".join(types)}, not {type_name}')


def graph_topic_type(node: Node, topic: str, wait: float | None) -> str:
    """The type of a topic from the graph, waiting up to ``wait`` seconds for it to appear;
    ``None``: only until the graph has answered, failing with the closest names."""
    name = node.resolve_name(topic)

    def found() -> list[str]:
        return node.graph.topics(node.scheme.namespace).get(name, [])

    if wait is None:
        require_on_graph(node, 'topics', name)
    else:
        node.graph.wait_until(found, wait)
    types = found()
    if not types:
        raise CommandError(
            f'topic {name} does not appear on the network: give its type, or check the name '
            '(zros topic list)'
        )
    if len(types) > 1:
        raise CommandError(f'topic {name} has several types ({", ".join(types)}): give one')
    return types[0]


def known_type(node: Node, topic: str, type_name: str) -> str:
    """``type_name``, after making sure ``node`` can decode it.

    A type zros cannot resolve is asked of the nodes publishing ``topic``, then of the other
    nodes serving ``~/get_type_description`` (ROS 2 nodes, a zros node playing a bag); the
    answer is registered. When nobody describes it, the UnknownTypeError says where zros looked
    and how to add the definition.
    """
    from zros.cdr.errors import UnknownTypeError
    from zros.services.typeinfo import SERVICE_NAME, learn_type

    try:
        node.registry.get_class(type_name)
        return type_name
    except UnknownTypeError as exc:
        unknown = exc
    key = node.scheme.key(node.resolve_name(topic))
    publishers = [e for e in node.graph.publishers(key) if e.type_name == type_name]
    owners = {e.node: e.type_hash for e in publishers if e.node}
    type_hash = next((e.type_hash for e in publishers if e.type_hash), None)
    suffix = '/' + SERVICE_NAME
    for service in names_on_graph(node, 'services'):
        if service.endswith(suffix):
            owners.setdefault(service[: -len(suffix)], type_hash)
    if learn_type(node, type_name, owners.items(), timeout=DISCOVERY) is not None:
        return type_name
    asked = ', '.join(owners) or 'none serves ~/get_type_description'
    raise CommandError(f'{unknown}\nThe nodes on the network did not describe it ({asked}).')


def subscription_type(node: Node, topic: str, type_name: str | None, wait: float | None) -> str:
    """The type to subscribe to ``topic`` with: ``type_name`` when given (refused when the graph
    advertises another), else the graph's (:func:`graph_topic_type`); made known to ``node``."""
    if not type_name:
        return known_type(node, topic, graph_topic_type(node, topic, wait))
    type_name = known_type(node, topic, type_name)
    require_advertised_type(node, 'topics', topic, node.registry.get_class(type_name).__msgtype__)
    return type_name


def build_message(cls: type[Message], values: dict[str, object]) -> Message:
    """A message of ``cls`` with ``values`` (nested dicts for nested fields), checked before
    anything is sent: a wrong field name or value is a usage error naming the field."""
    from zros.cdr.errors import CdrError, FieldError
    from zros.cdr.message import encode

    try:
        message = cls.from_dict(values)
        encode(message)  # what only encoding checks: integer ranges, bounds, float32 overflow
    except (FieldError, CdrError) as exc:
        raise UsageError(str(exc)) from None
    except (TypeError, ValueError) as exc:
        raise UsageError(f'cannot make a {cls.__msgtype__} from {values}: {exc}') from None
    return message


class Terminated(KeyboardInterrupt):
    """SIGTERM (``docker stop``, systemd), raised where Ctrl-C raises KeyboardInterrupt."""


@contextmanager
def sigterm_as_ctrl_c() -> Iterator[None]:
    """While a command runs, SIGTERM ends it as Ctrl-C does (a :class:`Terminated`), instead of
    killing the process before it closes what it holds; :func:`stop_on_signals` inside takes
    over. Only on the main thread, and only where nobody chose another SIGTERM handler."""
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    ):
        yield
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        raise Terminated

    signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


@contextmanager
def stop_on_signals(stop: threading.Event) -> Iterator[None]:
    """SIGINT and SIGTERM set ``stop`` instead of killing the process (restored after).

    The handler runs on the main thread between two bytecodes, possibly inside ``stop.wait()``
    while that holds the event's lock: setting the event there would wait for that lock for
    ever. A thread of its own sets it, once the main thread lets go."""

    def handler(signum: int, frame: FrameType | None) -> None:
        threading.Thread(target=stop.set, name='zros stop signal', daemon=True).start()

    saved = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, previous in saved.items():
            signal.signal(sig, previous)


def serve_until_interrupted(announce: str) -> int:
    """Print ``announce`` and wait for Ctrl-C while a server runs on threads of its own; exit
    code 0. The line is printed inside the wait: a signal sent as soon as it is read (a
    supervisor, a test) still ends the command as Ctrl-C does."""
    idle = threading.Event()  # never set: a sleep Ctrl-C interrupts
    try:
        out(announce)
        while not idle.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    return 0


def port_number(text: str) -> int:
    """An argparse type: a TCP port, 0 to 65535 (0: any free one)."""
    value = int(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f'a port is 0 to 65535, not {text}')
    return value


def at_least_one(text: str) -> int:
    """An argparse type: an integer of at least 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f'must be at least 1, not {text}')
    return value


_UNITS = {'': 1, 'k': 1000, 'kb': 1000, 'kib': 1024, 'm': 1000**2, 'mb': 1000**2,
          'mib': 1024**2, 'g': 1000**3, 'gb': 1000**3, 'gib': 1024**3}  # fmt: skip


def byte_count(text: str) -> int:
    """An argparse type: a size of at least 1 byte, as ``33554432``, ``32MiB`` or ``500kB``."""
    spelled = text.strip().lower()
    unit = spelled.lstrip('0123456789.')
    factor = _UNITS.get(unit.strip())
    try:
        size = int(float(spelled[: len(spelled) - len(unit)]) * factor) if factor else 0
    except ValueError:
        size = 0
    if size < 1:
        raise argparse.ArgumentTypeError(
            f'a size in bytes, as 33554432, 32MiB or 500kB, of at least 1 byte, not {text}'
        )
    return size


class _TheErrorSaysIt(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        from zros.transport.session import LINK_LOST

        return record.msg != LINK_LOST


def errors_tell_of_lost_links() -> None:
    """From now on (a command's calls or goals are under way) a lost link ends the command
    with an error that says so: the transport's own warning of the loss, which may come a moment
    before or after, would say it twice."""
    logging.getLogger('zros.transport').addFilter(_TheErrorSaysIt())


def out(text: str = '') -> None:
    """Print and flush (output often goes to a pipe another program reads line by line)."""
    sys.stdout.write(text + '\n')
    sys.stdout.flush()
