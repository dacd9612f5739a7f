"""Entry point of the ``zros`` command: parses arguments, then imports only what runs."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from zros import __version__


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='zros',
        description='zros: a ROS 2 client over Eclipse Zenoh, for machines with no ROS installed.',
    )
    parser.add_argument('--version', action='version', version=f'zros {__version__}')
    commands = parser.add_subparsers(dest='command', metavar='COMMAND')

    demo = commands.add_parser('demo', help='run the rosR sensor tutorial')
    demo.set_defaults(run='zros.cli.demo:run')

    interface = commands.add_parser('interface', help='show message, service and action types')
    verbs = interface.add_subparsers(dest='verb', metavar='VERB', required=True)
    show = verbs.add_parser('show', help='print the definition of a type')
    show.add_argument('type', help='e.g. geometry_msgs/msg/Twist')
    show.add_argument('--hash', action='store_true', help='also print the RIHS01 type hash')
    show.add_argument('--all', action='store_true', help='append the definitions it depends on')
    show.set_defaults(run='zros.cli.interface:show')
    listing = verbs.add_parser('list', help='list the types zros can resolve')
    listing.add_argument('pattern', nargs='?', default='', help='only names containing this text')
    listing.set_defaults(run='zros.cli.interface:list_types')

    from zros.cli import action, node, param, service, tls, topic

    for module in (topic, node, service, action, param, tls):
        module.add_parser(commands)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    parser = _parser()
    args = parser.parse_args(argv)
    target = getattr(args, 'run', None)
    if target is None:
        parser.print_help()
        return 2
    module_name, function_name = target.split(':')
    import importlib

    from zros.cli.common import CommandError
    from zros.errors import ZrosError

    function = getattr(importlib.import_module(module_name), function_name)
    try:
        return int(function(args))
    except (ZrosError, CommandError) as exc:
        print(f'zros: error: {exc}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == '__main__':
    sys.exit(main())
