"""``zros foxglove``: serve the robot (or a bag) to the Foxglove app, as foxglove_bridge does.

Runs until Ctrl-C. Prints the address to open in Foxglove (Open connection > Foxglove
WebSocket).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterable

from zros.cli.arg_types import at_least_one
from zros.cli.gateway_options import (
    ListenSettings,
    add_gateway_safety_options,
    add_name_filters,
    gateway_parser,
    listen_settings,
    serve_gateway,
)
from zros.cli.shared import CommandError, add_connection_options, open_node
from zros.gateway.common.limits import FOXGLOVE_PORT


class _Settings(ListenSettings):
    """The options of ``zros.foxglove.serve`` the command line gives in both modes."""

    topics: Iterable[str] | None
    exclude: Iterable[str] | None
    asset_paths: Iterable[str | os.PathLike[str]]
    message_backlog: int


def _settings(args: argparse.Namespace) -> _Settings:
    from zros.gateway.common.origins import FOXGLOVE_APP

    return {
        **listen_settings(args, [FOXGLOVE_APP]),
        'topics': args.topics,
        'exclude': args.exclude,
        'asset_paths': args.asset_path or (),
        'message_backlog': args.message_backlog,
    }


def run(args: argparse.Namespace) -> int:
    from zros.gateway.common.heap import keep_large_blocks
    from zros.gateway.foxglove.server import FoxgloveGateway, serve

    keep_large_blocks()  # this process relays big messages: reuse their buffers
    if args.bag is not None:
        if args.throttle:
            raise CommandError('--throttle applies to live topics, not to a bag')
        server = serve(bag=args.bag, **_settings(args))
        return serve_gateway(
            server, f'Foxglove: {server.url} serves {args.bag} (paused; play it from Foxglove)'
        )
    with open_node(args) as node:
        gateway = serve(
            node=node,
            services=args.services,
            params=args.params,
            include_hidden=args.include_hidden,
            sim_time=args.sim_time,
            throttle=args.throttle,
            read_only=args.read_only,
            **_settings(args),
        )
        assert isinstance(gateway, FoxgloveGateway)  # not a bag: a live gateway
        sim = ', sim time from /clock' if gateway.sim_time else ''
        read_only = ', read-only' if gateway.read_only else ''
        return serve_gateway(gateway, f'Foxglove: {gateway.url} ({node.wire} wire{sim}{read_only})')


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    parser = gateway_parser(commands, 'foxglove', help_line, run, FOXGLOVE_PORT)
    add_name_filters(parser, 'REGEX', {
        '--topics': 'offer only topics matching one of these (whole names)',
        '--exclude': 'never offer topics matching one of these',
        '--services': 'offer only services matching one of these',
        '--params': 'offer only parameters (/node.name) matching these',
    })  # fmt: skip
    parser.add_argument('--include-hidden', action='store_true',
                        help='also topics and services with a part starting with _')  # fmt: skip
    parser.add_argument('--asset-path', action='append', metavar='DIR',
                        help='serve package:// files (meshes) from DIR (repeatable)')  # fmt: skip
    parser.add_argument('--bag', metavar='PATH',
                        help='serve this recording instead of the live graph')  # fmt: skip
    parser.add_argument('--message-backlog', type=at_least_one, default=32, metavar='N',
                        help='messages the Foxglove SDK queues per client on their way out '
                        '(default 32; --client-buffer bounds the bytes)')  # fmt: skip
    parser.add_argument('--sim-time', action=argparse.BooleanOptionalAction, default=None,
                        help='publish /clock as the server time (default: if /clock has a '
                        'publisher at the start)')  # fmt: skip
    add_gateway_safety_options(parser, ' and https://app.foxglove.dev (the Foxglove web app)')
    add_connection_options(parser)
