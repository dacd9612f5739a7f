"""The start the examples share: connect where the user says, else run a Zenoh router here.

Each example takes ``--connect`` (default: ``$ZROS_CONNECT``). With neither there is nothing to
connect to, so the example starts a Zenoh router inside itself (and, where it needs the other
side, a stand-in for it), and runs anywhere.
"""

from __future__ import annotations

import argparse
import os

import zros
from zros.transport import Router


class ShowDefaults(argparse.ArgumentDefaultsHelpFormatter):
    """``--help`` shows each option's default, where it has one (not "None")."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None:
            return action.help
        return super()._get_help_string(action)


def add_connect(parser: argparse.ArgumentParser) -> None:
    """The ``--connect`` option every example has."""
    parser.add_argument(
        '--connect', help='router or bridge endpoint (default: $ZROS_CONNECT, else a router here)'
    )


def router_unless_given(connect: str | None, also: str = '') -> tuple[Router | None, str | None]:
    """``(router, endpoint)``: ``(None, connect)`` when ``connect`` or ``$ZROS_CONNECT`` says
    where to go, else a router started here and its endpoint (``also``: what else runs here
    then, for the line that says so). Close the router at the end."""
    if connect or os.environ.get('ZROS_CONNECT'):
        return None, connect
    router = zros.start_router()
    here = f'and {also} run here' if also else 'runs inside this script'
    print(f'no robot given: a Zenoh router at {router.endpoint} {here}')
    return router, router.endpoint
