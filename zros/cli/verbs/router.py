"""``zros router``: a Zenoh router in the foreground, for trying zros without a robot.

Listens on ``tcp/127.0.0.1:7447`` (this machine only) unless ``--listen`` says otherwise, and
warns when other machines can reach it. With ``--tls-cert`` and ``--tls-key`` it listens on
TLS only; with ``--tls-ca`` too, clients need a certificate that CA signed (mutual TLS). With
``--user``, clients must present that user and the password read from ``ZROS_PASSWORD`` (or
typed at a prompt): never from the command line, where ``ps`` would show it. Large messages
sent with Zenoh's defaults (rmw_zenoh's, for one) leave it as ``data_low`` and ``block_first``
unless ``--keep-qos``; ``--downsample /topic=HZ`` caps a topic's rate out of each link. Runs
until Ctrl-C or SIGTERM, then exits 0.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import threading

from zros.cli.shared import CommandError, out
from zros.cli.signals import stop_on_signals

DEFAULT_LISTEN = 'tcp/127.0.0.1:7447'
DEFAULT_TLS_LISTEN = 'tls/127.0.0.1:7447'


def _password(user: str | None) -> str | None:
    if user is None:
        return None
    password = os.environ.get('ZROS_PASSWORD')
    if password:
        return password
    if not sys.stdin.isatty():
        raise CommandError(f'--user {user} needs a password: set ZROS_PASSWORD')
    import getpass

    return getpass.getpass(f'password for {user}: ')


def _warn_if_exposed(endpoints: list[str], guarded: bool) -> None:
    from zros.transport.endpoints import parse_endpoint

    exposed = [e for e in endpoints if not parse_endpoint(e).loopback]
    if not exposed:
        return
    risk = '' if guarded else '; without --tls-* or --user, anyone who reaches it joins the graph'
    print(
        f'zros router: warning: {", ".join(exposed)} accepts connections from other machines{risk}',
        file=sys.stderr,
        flush=True,
    )


def _suggested(endpoints: list[str], certificate: str | None) -> str:
    """The endpoint to dial: with TLS, one at a host the certificate names (clients check)."""
    if certificate is None:
        return endpoints[0]
    from zros.transport.endpoints import parse_endpoint
    from zros.transport.tlsfiles import first_named

    for endpoint in endpoints:
        parsed = parse_endpoint(endpoint)
        hosts = [parsed.host, *(['localhost'] if parsed.loopback else [])]
        host = first_named(certificate, hosts)
        if host is not None:
            return str(dataclasses.replace(parsed, host=host))
    return endpoints[0]


def run(args: argparse.Namespace) -> int:
    from zros.transport import start_router
    from zros.transport.endpoints import normalize

    tls = args.tls_cert is not None or args.tls_key is not None or args.tls_ca is not None
    listen = [normalize(e) for e in args.listen or [DEFAULT_TLS_LISTEN if tls else DEFAULT_LISTEN]]
    password = _password(args.user)
    _warn_if_exposed(listen, tls or args.user is not None)
    stop = threading.Event()
    with stop_on_signals(stop):
        router = start_router(
            listen,
            shared_memory=args.shared_memory,
            certificate=args.tls_cert,
            private_key=args.tls_key,
            client_ca=args.tls_ca,
            user=args.user,
            password=password,
            large_payloads=not args.keep_qos,
            downsample=dict(args.downsample or ()),
        )
        with router:
            for endpoint in router.endpoints:
                out(f'zros router listening on {endpoint}')
            if args.tls_ca:
                out(f'  clients need a certificate signed by {args.tls_ca} (mutual TLS)')
            if args.user:
                out(f'  clients must log in as {args.user!r}')
            if not args.keep_qos:
                out('  large messages (64 KiB on) sent with drop leave as block_first')
            for topic, rate in args.downsample or ():
                out(f'  {topic}: at most {rate:g} messages a second out of each link')
            endpoint = _suggested(router.endpoints, args.tls_cert)
            out(f'  connect with --connect {endpoint} or ZROS_CONNECT={endpoint}')
            out('  Ctrl-C stops it')
            while not stop.wait(0.5):
                pass
    return 0


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    parser = commands.add_parser(
        'router',
        help=help_line,
        description=__doc__,
    )
    parser.add_argument(
        '--listen',
        action='append',
        metavar='ENDPOINT',
        help=f'where to listen (repeat; default {DEFAULT_LISTEN}, {DEFAULT_TLS_LISTEN} with TLS)',
    )
    group = parser.add_argument_group('security')
    group.add_argument('--tls-cert', metavar='FILE', help="the router's certificate (PEM)")
    group.add_argument('--tls-key', metavar='FILE', help='its private key (PEM)')
    group.add_argument(
        '--tls-ca', metavar='FILE', help='require client certificates signed by this CA'
    )
    group.add_argument(
        '--user', metavar='NAME', help='require this user, with the password in $ZROS_PASSWORD'
    )
    parser.add_argument(
        '--shared-memory', action='store_true', help="Zenoh's shared memory for local clients"
    )
    group = parser.add_argument_group('slow links')
    group.add_argument(
        '--downsample', action='append', type=_topic_rate, metavar='TOPIC=HZ',
        help='send a topic at most HZ times a second out of each link (repeat; * and ** match)',
    )  # fmt: skip
    group.add_argument(
        '--keep-qos', action='store_true',
        help="leave large messages' priority and congestion control as sent (default: 64 KiB "
        'on, sent with the defaults, go as data_low and block_first)',
    )  # fmt: skip
    parser.set_defaults(run=run)


def _topic_rate(text: str) -> tuple[str, float]:
    """An argparse type: ``/topic=HZ``, HZ > 0."""
    topic, _, rate = text.rpartition('=')
    try:
        hz = float(rate)
    except ValueError:
        hz = 0.0
    if not topic.strip('/') or '//' in topic or not hz > 0:
        raise argparse.ArgumentTypeError(
            f'give TOPIC=HZ with HZ > 0, as /camera/image=2, not {text}'
        )
    return topic, hz
