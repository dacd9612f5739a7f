"""``zros tls init``: certificates for a robot's router and the machines that reach it."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from zros.cli.shared import add_verbs


def init(args: argparse.Namespace) -> int:
    from zros.transport.pki import PEER_HOSTS, make_certificates

    # this machine's names too: the router's banner and a local test dial those
    hosts = list(dict.fromkeys([*(args.host or ()), *PEER_HOSTS]))
    clients = args.client or ['laptop']
    certificates = make_certificates(
        args.folder, hosts=hosts, clients=clients, days=args.days, overwrite=args.force
    )
    folder = certificates.folder.resolve()
    config = folder / 'router.json5'
    descriptor = os.open(config, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(descriptor, 'w') as file:
        file.write(certificates.router_config(f'tls/[::]:{args.port}', mutual=not args.server_only))
    mutual = 'mutual TLS' if not args.server_only else 'TLS (server certificate only)'
    print(f'Made a CA and certificates for {mutual} in {folder}:')
    print('  ca.pem, ca.key        the CA; keep ca.key off the robot, it signs certificates')
    print('  router.json5          the robot side, certificates inlined: copy it to the robot')
    print('                        and run  zenoh-bridge-ros2dds -c router.json5  (or zenohd -c)')
    mutual_option = '' if args.server_only else ' --tls-ca ca.pem'
    print(f'                        or  zros router --listen tls/[::]:{args.port} \\')
    print(
        f'                              --tls-cert router.pem --tls-key router.key{mutual_option}'
    )
    for name in clients:
        print(f'  {name}.pem, {name}.key  the client {name!r}')
    print()
    print(f'On {clients[0]!r}, every zros program then connects with:')
    print(f'  export ZROS_CONNECT=tls/{hosts[0]}:{args.port}')
    print(f'  export ZROS_TLS_CA={certificates.ca.resolve()}')
    if not args.server_only:
        print(
            f'  export ZROS_TLS_CERTIFICATE={certificates.client_certificate(clients[0]).resolve()}'
        )
        print(f'  export ZROS_TLS_KEY={certificates.client_key(clients[0]).resolve()}')
    print(f'The router certificate names {", ".join(hosts)}: dial one of those.')
    return 0


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    verbs = add_verbs(commands, 'tls', help_line)
    make = verbs.add_parser(
        'init',
        help='a CA, a router certificate and client certificates, and the router config',
        description="Write a private CA, a certificate for the robot's router (bridge) naming "
        'every host you dial it by, a certificate per client, and router.json5 for the robot.',
    )
    make.add_argument('folder', type=Path, help='where to write the files')
    make.add_argument(
        '--host',
        action='append',
        help='a name or address the robot is reached at (repeat; localhost, 127.0.0.1 and ::1 are '
        'always named)',
    )
    make.add_argument('--client', action='append', help='a client name (repeat; default laptop)')
    make.add_argument('--port', type=int, default=7447, help='the TLS port of the router')
    make.add_argument('--days', type=int, default=365, help='validity (default 365)')
    make.add_argument(
        '--server-only', action='store_true', help='clients need no certificate (plain TLS)'
    )
    make.add_argument('--force', action='store_true', help='overwrite existing files')
    make.set_defaults(run=init)
