"""What ``zros foxglove`` and ``zros rosbridge`` share: the parser with where they listen and
what clients may do, their name filters' shape, the settings every gateway's ``serve`` takes,
and serving until Ctrl-C."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING, TypedDict

from zros.cli.arg_types import at_least_one, byte_count, port_number
from zros.cli.signals import serve_until_interrupted
from zros.gateway.common.limits import CLIENT_BUFFER, MAX_CLIENTS
from zros.version import install_hint

if TYPE_CHECKING:
    from zros.closing import Closing


class ListenSettings(TypedDict):
    """The keywords both gateways' ``serve`` take from the shared options."""

    port: int
    address: str
    tls_cert: str | None
    tls_key: str | None
    client_buffer: int
    max_clients: int
    allow_origins: Iterable[str]


def gateway_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser],
    name: str,
    help_line: str,
    run: Callable[[argparse.Namespace], int],
    port: int,
) -> argparse.ArgumentParser:
    """The parser of gateway command ``name`` (its extra has the same name), with where it
    listens: ``--port`` (``port`` by default), ``--address`` and the TLS certificate and key
    that make it ``wss://``."""
    parser = commands.add_parser(
        name,
        help=help_line,
        description=f'{help_line}. Needs the {name} extra: {install_hint(name)}.',
    )
    parser.set_defaults(run=run)
    parser.add_argument('--port', type=port_number, default=port,
                        help=f'TCP port (default {port}; 0: any)')  # fmt: skip
    parser.add_argument('--address', default='127.0.0.1',
                        help='address to listen on (default 127.0.0.1; others warn)')  # fmt: skip
    parser.add_argument('--tls-cert', metavar='PEM', help='certificate: serve wss://')
    parser.add_argument('--tls-key', metavar='PEM', help='its private key')
    return parser


def add_name_filters(
    parser: argparse.ArgumentParser, metavar: str, flags: Mapping[str, str]
) -> None:
    """Name filters, one or more patterns each (repeatable): ``flags`` maps each flag to its
    help. The gateways keep the flags and pattern syntax of the servers they stand in for
    (foxglove_bridge's regular expressions, rosbridge's globs)."""
    for flag, help_text in flags.items():
        parser.add_argument(flag, nargs='+', action='extend', metavar=metavar, help=help_text)


def add_gateway_safety_options(parser: argparse.ArgumentParser, default_origins: str) -> None:
    """The options both gateway commands share: which browsers may connect, whether clients
    may act on the robot, the rate of topics, the bytes queued per client and how many clients
    are served at once.
    ``default_origins`` says in the help which origins the command allows besides this
    machine's pages."""
    parser.add_argument('--allow-origin', action='append', default=[], metavar='ORIGIN',
                        help='also accept browsers on pages of ORIGIN (https://host[:port]; '
                        f"repeatable; '*': any page). Default: pages of this machine"
                        f'{default_origins}; programs (no Origin header) are always accepted'
                        )  # fmt: skip
    parser.add_argument('--read-only', action='store_true',
                        help='clients may only watch: no publishing, service calls, parameter '
                        'sets or action goals')  # fmt: skip
    parser.add_argument('--throttle', action='append', default=[], metavar='REGEX=HZ',
                        help="at most HZ messages a second of these ('/camera/.*=2')")  # fmt: skip
    parser.add_argument('--client-buffer', type=byte_count, default=CLIENT_BUFFER,
                        metavar='BYTES', help='bytes queued per client before its oldest '
                        'messages are dropped (default 32MiB)')  # fmt: skip
    parser.add_argument('--max-clients', type=at_least_one, default=MAX_CLIENTS, metavar='N',
                        help='connections served at once; more get HTTP 503 (default '
                        f'{MAX_CLIENTS})')  # fmt: skip


def listen_settings(args: argparse.Namespace, origins: Iterable[str] = ()) -> ListenSettings:
    """The shared options' values for ``serve``; ``origins``: those the gateway allows besides
    ``--allow-origin``'s."""
    return {
        'port': args.port,
        'address': args.address,
        'tls_cert': args.tls_cert,
        'tls_key': args.tls_key,
        'client_buffer': args.client_buffer,
        'max_clients': args.max_clients,
        'allow_origins': [*origins, *args.allow_origin],
    }


def serve_gateway(gateway: Closing, line: str) -> int:
    """Print ``line`` (the address to open) and serve until Ctrl-C; the gateway closes after."""
    with gateway:
        return serve_until_interrupted(line)
