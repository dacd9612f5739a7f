"""``zros rosbridge``: serve the robot to web apps built on roslibjs and roslibpy, as
rosbridge_server (with rosapi) does.

Runs until Ctrl-C. Prints the address to give ``new ROSLIB.Ros({url})``.
"""

from __future__ import annotations

import argparse

from zros.cli.arg_types import at_least_one
from zros.cli.gateway_options import (
    add_gateway_safety_options,
    add_name_filters,
    gateway_parser,
    listen_settings,
    serve_gateway,
)
from zros.cli.shared import add_connection_options, open_node
from zros.gateway.common.limits import ROSBRIDGE_PORT


def globs(values: list[str] | None) -> list[str]:
    """Globs from the command line; rosbridge's list syntax (``"['/a', '/b*']"``) is read too."""
    found = []
    for value in values or ():
        if value.startswith('[') and value.endswith(']'):
            found += [g.strip().strip('\'"') for g in value[1:-1].split(',') if g.strip(' \'"')]
        else:
            found.append(value)
    return found


def run(args: argparse.Namespace) -> int:
    from zros.gateway.rosbridge.server import serve

    with open_node(args) as node:
        gateway = serve(
            node=node,
            topics_glob=globs(args.topics_glob),
            services_glob=globs(args.services_glob),
            params_glob=globs(args.params_glob),
            max_message_size=args.max_message_size,
            queue_items=args.client_queue,
            read_only=args.read_only,
            allow_service_override=args.allow_service_override,
            throttle=args.throttle,
            **listen_settings(args),
        )
        read_only = ', read-only' * args.read_only
        return serve_gateway(gateway, f'rosbridge: {gateway.url} ({node.wire} wire{read_only})')


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    parser = gateway_parser(commands, 'rosbridge', help_line, run, ROSBRIDGE_PORT)
    add_name_filters(parser, 'GLOB', {
        '--topics-glob': 'allow only topics matching one of these ("/camera/*")',
        '--services-glob': 'allow only services and actions matching these',
        '--params-glob': 'allow only parameters (/node:name) matching these',
    })  # fmt: skip
    parser.add_argument('--max-message-size', type=at_least_one, default=10_000_000,
                        metavar='BYTES', help='largest message a client may send; longer JSON '
                        'to clients goes as fragments (default 10000000)')  # fmt: skip
    parser.add_argument('--client-queue', type=at_least_one, default=1000, metavar='N',
                        help='messages queued per client before its oldest are dropped '
                        '(default 1000; --client-buffer bounds their bytes)')  # fmt: skip
    add_gateway_safety_options(parser, '')
    parser.add_argument('--allow-service-override', action='store_true',
                        help='let clients serve services and actions another node of the graph '
                        'serves already')  # fmt: skip
    add_connection_options(parser)
