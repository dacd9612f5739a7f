"""What the ``zros`` subcommands share: connection options, the command node, values, exits
(the graph lookups, signals and argparse types have modules of their own beside it).

Exit codes: 0 success, 1 a failure the message explains, 2 a usage error (argparse, a setting
that cannot work such as a malformed endpoint, or a field name or value a message type refuses),
130 interrupted before finishing, 141 the reader of the output went away (``| head``; no
traceback). Continuous commands (echo, hz...) stopped with Ctrl-C exit 0.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable
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
