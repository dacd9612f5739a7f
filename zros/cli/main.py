"""Entry point of the ``zros`` command: parses arguments, then imports only what runs."""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Callable, Container, Sequence

from zros.version import __version__

TYPE_CHECKING = False  # not typing's: importing typing would slow ``zros --help``
if TYPE_CHECKING:
    from types import ModuleType

#: every command, in the order ``zros --help`` lists them, with its help line (written only here;
#: the module gets it as an argument). A command's module is ``zros.cli.verbs.<command>``, named
#: by its verb: its ``add_parser(commands, help_line)`` adds the parser, and each parser's
#: ``run`` default is the function that runs it. The module is imported only when the command
#: is chosen, or when the whole tree is needed (completion, docs).
COMMANDS: dict[str, str] = {
    'demo': 'run the rosR sensor tutorial',
    'topic': 'topics: list, echo, pub, hz...',
    'node': 'nodes: list, info',
    'service': 'services: list, type, find, call',
    'action': 'actions: list, info, type, send_goal',
    'param': 'parameters: list, get, set, describe, dump...',
    'interface': 'message, service and action types',
    'bag': 'read, record and play recordings',
    'plot': 'plot topic fields, live or from a bag',
    'graph': 'draw the ROS graph (rqt_graph)',
    'tf': 'frames: echo a transform, show the tree (tf2_echo, view_frames)',
    'foxglove': 'serve the robot, or a bag, to the Foxglove app (as foxglove_bridge)',
    'rosbridge': 'serve the robot to roslibjs and roslibpy apps (as rosbridge_server and rosapi)',
    'doctor': 'check the connection, bridges, versions and clocks',
    'router': 'run a Zenoh router here (for trying zros without a robot)',
    'tls': 'make certificates for TLS to a robot',
    'completion': 'print a shell completion script',
}

#: the package holding one module per command, named by the command
VERBS = 'zros.cli.verbs'


def verb_module(command: str) -> ModuleType:
    """The module of ``command`` (``zros.cli.verbs.<command>``), imported."""
    return importlib.import_module(f'{VERBS}.{command}')


def build_parser(full: Container[str] = COMMANDS) -> argparse.ArgumentParser:
    """The parser of ``zros``: the commands in ``full`` (default: all) with their whole tree,
    the others with only their name and help line (enough for ``zros --help``)."""
    parser = argparse.ArgumentParser(
        prog='zros',
        description='zros: a ROS 2 client over Eclipse Zenoh, for machines with no ROS installed.',
    )
    parser.add_argument('--version', action='version', version=f'zros {__version__}')
    # a command that describes the command line itself (completion) builds it from its arguments
    parser.set_defaults(full_parser=build_parser)
    commands = parser.add_subparsers(dest='command', metavar='COMMAND')
    for name, help_line in COMMANDS.items():
        if name in full:
            verb_module(name).add_parser(commands, help_line)
        else:  # never parsed: ``_run`` builds the tree of the command it parses
            commands.add_parser(name, help=help_line, add_help=False)
    return parser


def chosen_command(argv: Sequence[str]) -> str | None:
    """The command ``argv`` names: its first word that is not an option (``zros`` itself has
    only ``--help`` and ``--version``, which take no value), if it is a command."""
    first = next((word for word in argv if not word.startswith('-')), None)
    return first if first in COMMANDS else None


#: the exit code when the reader of our output went away (``zros interface list | head``):
#: 128 + SIGPIPE, what a shell reports for ``cat`` or ``git log`` in the same place
PIPE_CLOSED = 141


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    try:
        try:
            return _run(argv)
        finally:
            sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
    except BrokenPipeError:
        # Later writes, and the flush at interpreter exit, go nowhere instead of raising again.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return PIPE_CLOSED


def _run(argv: Sequence[str] | None) -> int:
    words = sys.argv[1:] if argv is None else list(argv)
    command = chosen_command(words)
    parser = build_parser(() if command is None else (command,))
    args = parser.parse_args(words)
    target = getattr(args, 'run', None)
    if target is None:
        parser.print_help()
        return 2
    # only a command that runs needs these (keeps ``zros --help`` start-up fast)
    from zros.cli.shared import CommandError
    from zros.cli.signals import Terminated, sigterm_as_ctrl_c
    from zros.errors import SettingError, ZrosError, command_line_text

    function: Callable[[argparse.Namespace], int] = target
    try:
        with sigterm_as_ctrl_c():
            return int(function(args))
    except SettingError as exc:  # a setting that cannot work, as argparse's usage errors
        print(f'zros: error: {command_line_text(exc)}', file=sys.stderr)
        return 2
    except (ZrosError, CommandError) as exc:
        print(f'zros: error: {command_line_text(exc)}', file=sys.stderr)
        return exc.exit_code if isinstance(exc, CommandError) else 1
    except KeyboardInterrupt as exc:  # a command that let Ctrl-C or SIGTERM end it
        return 143 if isinstance(exc, Terminated) else 130


if __name__ == '__main__':
    sys.exit(main())
