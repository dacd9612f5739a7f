"""``python -m tests.interop.bridge_standin --listen <endpoint> [--namespace /bot1]``.

Prints ``READY <zid>`` on stdout once both sides are up; stops on SIGTERM or SIGINT.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys

from tests.interop.bridge_standin.runtime import Options, StandIn


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='bridge_standin', description=__doc__)
    parser.add_argument('--listen', action='append', required=True, help='Zenoh endpoint')
    parser.add_argument('--namespace', '-n', default='/')
    parser.add_argument('--nodename', default='zenoh_bridge_ros2dds')
    parser.add_argument('--version', default='1.10.0')
    parser.add_argument(
        '--domain', '-d', type=int, default=int(os.environ.get('ROS_DOMAIN_ID', '0'))
    )
    parser.add_argument('--log-level', default='INFO')
    args = parser.parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(),
        stream=sys.stderr,
        format='%(asctime)s standin %(levelname)s %(message)s',
    )
    bridge = StandIn(
        Options(
            listen=args.listen,
            namespace=args.namespace,
            nodename=args.nodename,
            version=args.version,
            domain=args.domain,
        )
    )
    signal.signal(signal.SIGTERM, lambda *_: bridge.stop())
    signal.signal(signal.SIGINT, lambda *_: bridge.stop())
    print(f'READY {bridge.zid}', flush=True)
    try:
        bridge.run()
    finally:
        bridge.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
