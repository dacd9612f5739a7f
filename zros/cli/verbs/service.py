"""``zros service``: list, type, find, call (as ``ros2 service``)."""

from __future__ import annotations

import argparse
import time
from typing import TYPE_CHECKING

from zros.cli.graph_lookup import (
    add_listing_options,
    find_names,
    list_names,
    print_types,
    require_advertised_type,
    require_on_graph,
)
from zros.cli.shared import (
    WAIT,
    CommandError,
    add_verb,
    add_verbs,
    add_wait_option,
    build_message,
    errors_tell_of_lost_links,
    open_node,
    out,
    parse_values,
)
from zros.errors import command_line_text

if TYPE_CHECKING:
    from zros.cdr import Message
    from zros.cdr.interfaces import ServiceType
    from zros.services import Client


def _service_type(type_name: str) -> ServiceType:
    from zros.cdr import default_registry
    from zros.cdr.interfaces import ServiceType

    found = default_registry().get_type(type_name)
    if not isinstance(found, ServiceType):
        raise CommandError(f'{type_name} is not a service type')
    return found


def list_services(args: argparse.Namespace) -> int:
    return list_names(args, 'services')


def service_type(args: argparse.Namespace) -> int:
    return print_types(args, 'services', args.service)


def find(args: argparse.Namespace) -> int:
    return find_names(args, 'services', _service_type(args.type).__srvtype__)


def call(args: argparse.Namespace) -> int:
    srv = _service_type(args.type)
    values = parse_values(args.values)
    with open_node(args) as node:
        if args.wait is None:  # before our own client shows the name on the graph
            require_on_graph(node, 'services', node.resolve_name(args.service))
        require_advertised_type(node, 'services', args.service, srv.__srvtype__)
        client = node.create_client(srv, args.service, timeout=args.timeout)
        request = build_message(client.Request, values)
        if not client.service_is_ready():
            wait = WAIT if args.wait is None else args.wait
            out('waiting for service to become available...')
            if not client.wait_for_service(wait):
                raise CommandError(
                    f'no server for {client.name} [{srv.__srvtype__}] appeared within {wait:g} s'
                )
        errors_tell_of_lost_links()
        rate = node.create_rate(args.rate) if args.rate else None
        times = args.times if rate is not None else 1  # 0: until Ctrl-C, as ros2's -r
        made = 0
        try:
            while True:
                _call_once(client, request, args)
                made += 1
                if (times and made >= times) or rate is None:
                    return 0
                rate.sleep()
                if not node.ok():
                    raise KeyboardInterrupt  # Ctrl-C ended the sleep
        except KeyboardInterrupt:
            if times:  # interrupted before the calls asked for were made: 130
                raise
            return 0  # repeating until Ctrl-C, as echo


def _call_once(client: Client, request: Message, args: argparse.Namespace) -> None:
    """One call of ``zros service call``, printed as ros2's."""
    from zros.cli.message_text import message_to_yaml
    from zros.services import ServiceError

    out(f'requester: making request: {request!r}')
    out()
    started = time.monotonic()
    try:
        response = client.call(request)
    except ServiceError as exc:
        raise CommandError(command_line_text(exc)) from None
    elapsed = time.monotonic() - started
    out('response:')
    out(message_to_yaml(response).rstrip('\n') if args.yaml else repr(response))
    if args.verbose:
        out(f'(answered in {elapsed * 1000:.1f} ms)')
    out()


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'service', help_line)

    listing = add_verb(verbs, 'list', 'list the services on the network', list_services)
    listing.add_argument('-t', '--show-types', action='store_true', help='with their types')
    add_listing_options(listing, 'services')
    add_verb(verbs, 'type', 'the type of a service', service_type).add_argument('service')
    finding = add_verb(verbs, 'find', 'the services of a type', find)
    finding.add_argument('type')
    add_listing_options(finding, 'services')
    sub = add_verb(verbs, 'call', 'call a service and print the response', call)
    sub.add_argument('service', help='e.g. /add_two_ints')
    sub.add_argument('type', help='e.g. example_interfaces/srv/AddTwoInts')
    sub.add_argument('values', nargs='?', help='the request as YAML, e.g. "{a: 1, b: 2}"')
    sub.add_argument(
        '-r', '--rate', type=float, default=0.0, help='repeat at this rate (Hz) until Ctrl-C'
    )
    sub.add_argument(
        '--times',
        type=int,
        default=0,
        help="with --rate: stop after this many calls (zros's own; default: until Ctrl-C)",
    )
    sub.add_argument('--yaml', action='store_true', help='print the response as YAML')
    sub.add_argument('--timeout', type=float, default=10.0, help='seconds for each reply')
    add_wait_option(sub, 'service')
    sub.add_argument('-v', '--verbose', action='store_true', help='with the round-trip time')
