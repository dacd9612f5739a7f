"""``zros interface``: list, packages, package, show, proto (as ``ros2 interface``)."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING

from zros.cli.shared import CommandError, UsageError, add_verbs, out

_NO_SOURCES = '(no comments: no .msg sources found; set ZROS_INTERFACE_PATH)'

if TYPE_CHECKING:
    from zros.cdr.expand import Comments


def show(args: argparse.Namespace) -> int:
    """Print a type as ``ros2 interface show`` does: nested types expanded beneath their fields,
    comments of the type itself (``--all-comments``: of nested types too; ``--no-comments``:
    none). ``--all`` prints the bag format instead (the definition, then its dependencies);
    ``--hash`` adds the RIHS01 hash. Comments come from ``.msg`` sources (``ZROS_INTERFACE_PATH``,
    ``AMENT_PREFIX_PATH``, ROS 2 wheels); standard error says once which file, or that none
    was found."""
    from zros.cdr import default_registry
    from zros.cdr.expand import expanded_text, text_origin
    from zros.cdr.model import MessageDef
    from zros.cdr.render import render_bundle

    registry = default_registry()
    type_name = args.type
    if type_name == '-':  # ros2's form: zros topic type /chatter | zros interface show -
        type_name = sys.stdin.readline().strip()
        if not type_name:
            raise UsageError('expected a type name on standard input')
    definition = registry.definition(type_name)
    if args.all and isinstance(definition, MessageDef):
        text = render_bundle(registry, definition.name)
    else:
        comments: Comments = 'none' if args.no_comments else 'all' if args.all_comments else 'top'
        text = expanded_text(registry, definition.name, comments)
        if comments != 'none':
            # on stderr: stdout stays what ros2 interface show prints
            origin = text_origin(registry, definition.name)
            note = _NO_SOURCES if origin is None else f'(comments from {origin})'
            print(note, file=sys.stderr)
    sys.stdout.write(text)
    if args.hash:
        from zros.cdr.hashing import type_hash

        sys.stdout.write(f'# {type_hash(registry, definition.name)}\n')
    sys.stdout.flush()
    return 0


def proto(args: argparse.Namespace) -> int:
    """Print the default message of a type as YAML, in double quotes unless ``--no-quotes``, as
    ``ros2 interface proto`` does (a service: its request; an action: its goal), to edit into
    ``zros topic pub`` values."""
    from zros.cdr import default_registry
    from zros.cdr.interfaces import ActionType, ServiceType
    from zros.cli.message_text import message_to_yaml

    found = default_registry().get_type(args.type)
    if isinstance(found, ServiceType):
        message = found.Request()
    elif isinstance(found, ActionType):
        message = found.Goal()
    else:
        message = found()
    text = message_to_yaml(message)
    out(text if args.no_quotes else f'"{text}"')
    return 0


def _names(kind: str = '') -> list[str]:
    from zros.cdr import default_registry

    names = default_registry().names()
    return [name for name in names if not kind or f'/{kind}/' in name]


def list_types(args: argparse.Namespace) -> int:
    """Print every type name zros can resolve, one per line (``ros2 interface list`` groups
    them; zros prints plain names so that grep and scripts work)."""
    kinds = [k for k, wanted in (('msg', args.only_msgs), ('srv', args.only_srvs),
                                 ('action', args.only_actions)) if wanted]  # fmt: skip
    for name in _names():
        if args.pattern in name and (not kinds or name.split('/')[1] in kinds):
            out(name)
    return 0


def packages(args: argparse.Namespace) -> int:
    """Print the packages that have types."""
    for package in sorted({name.split('/')[0] for name in _names()}):
        out(package)
    return 0


def package(args: argparse.Namespace) -> int:
    """Print the types of one package."""
    found = [name for name in _names() if name.split('/')[0] == args.package]
    if not found:
        raise CommandError(f'no types of package {args.package} (zros interface packages)')
    for name in found:
        out(name)
    return 0


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'interface', help_line)
    show_parser = verbs.add_parser(
        'show', help='print the definition of a type, nested types expanded (as ros2)'
    )
    show_parser.add_argument(
        'type', help="e.g. geometry_msgs/msg/Twist; '-' reads it from standard input"
    )
    comments = show_parser.add_mutually_exclusive_group()
    comments.add_argument(
        '--all-comments', action='store_true', help='comments of nested types too'
    )
    comments.add_argument('--no-comments', action='store_true', help='no comments, no blank lines')
    show_parser.add_argument('--hash', action='store_true', help='also print the RIHS01 hash')
    show_parser.add_argument(
        '--all', action='store_true', help='the bag format: the text, then each dependency'
    )
    show_parser.set_defaults(run=show)
    prototype = verbs.add_parser('proto', help="a type's default message as YAML (as ros2)")
    prototype.add_argument('type', help='e.g. geometry_msgs/msg/Twist (a service: its request)')
    prototype.add_argument('--no-quotes', action='store_true', help='without the outer quotes')
    prototype.set_defaults(run=proto)
    listing = verbs.add_parser('list', help='list the types zros can resolve')
    listing.add_argument('pattern', nargs='?', default='', help='only names containing this')
    listing.add_argument('-m', '--only-msgs', action='store_true')
    listing.add_argument('-s', '--only-srvs', action='store_true')
    listing.add_argument('-a', '--only-actions', action='store_true')
    listing.set_defaults(run=list_types)
    verbs.add_parser('packages', help='list the packages that have types').set_defaults(
        run=packages
    )
    one = verbs.add_parser('package', help='list the types of a package')
    one.add_argument('package')
    one.set_defaults(run=package)
