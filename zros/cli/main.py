"""Entry point of the ``zros`` command: parses arguments, then imports only what runs."""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from collections.abc import Sequence

# the command modules are light: each imports what it runs inside the function that runs it
from zros.cli import (
    action,
    bag,
    completion,
    demo,
    doctor,
    foxglove_command,
    interface,
    node_command,
    param,
    plot,
    rosbridge_command,
    router_command,
    service,
    tls,
    topic,
)
from zros.cli.shared import CommandError
from zros.errors import SettingError, ZrosError
from zros.version import __version__


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='zros',
        description='zros: a ROS 2 client over Eclipse Zenoh, for machines with no ROS installed.',
    )
    parser.add_argument('--version', action='version', version=f'zros {__version__}')
    # a command that describes the command line itself (completion) finds it in its arguments
    parser.set_defaults(root_parser=parser)
    commands = parser.add_subparsers(dest='command', metavar='COMMAND')

    for module in (
        demo,
        topic,
        node_command,
        service,
        action,
        param,
        interface,
        bag,
        plot,
        foxglove_command,
        rosbridge_command,
        doctor,
        router_command,
        tls,
        completion,
    ):
        module.add_parser(commands)
    return parser


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
    parser = _parser()
    args = parser.parse_args(argv)
    target = getattr(args, 'run', None)
    if target is None:
        parser.print_help()
        return 2
    module_name, function_name = target.split(':')
    function = getattr(importlib.import_module(module_name), function_name)
    try:
        return int(function(args))
    except SettingError as exc:  # a setting that cannot work, as argparse's usage errors
        print(f'zros: error: {exc}', file=sys.stderr)
        return 2
    except (ZrosError, CommandError) as exc:
        print(f'zros: error: {exc}', file=sys.stderr)
        return exc.exit_code if isinstance(exc, CommandError) else 1
    except KeyboardInterrupt:
        return 130


if __name__ == '__main__':
    sys.exit(main())
