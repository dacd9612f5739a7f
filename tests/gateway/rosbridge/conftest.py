"""Fixtures of the rosbridge tests: gateways on the test router, and real clients.

* ``rosbridge``: ``make(**serve_options)`` -> a running ``RosbridgeGateway`` on a node of its
  own (of the module's ``zros_wire``), on a free port.
* ``roslibpy_client``: ``make(gateway)`` -> a connected ``roslibpy.Ros`` (asyncio transport,
  one event loop per client), closed after the test.
* ``roslibjs``: ``make(gateway)`` -> a :class:`RoslibClient`, roslib from npm run by node.
* ``raw_client``: ``make(gateway)`` -> a :class:`RawClient`, a plain WebSocket speaking the
  protocol by hand (for what the client libraries never send).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tests.gateway.rosbridge.clients import RawClient
from tests.gateway.rosbridge.roslib_client import RoslibClient, require_roslib
from zros.testing import wait_for

pytest.importorskip('websockets', reason='the websockets library (the rosbridge extra) is missing')


@pytest.fixture
def rosbridge(zros_node: Callable[..., Any]) -> Iterator[Callable[..., Any]]:
    from zros.gateway.rosbridge.server import serve

    made: list[Any] = []

    def make(**options: Any) -> Any:
        node = options.pop('node', None) or zros_node(
            'zros_rosbridge', enable_rosout=False, start_parameter_services=False
        )
        options.setdefault('port', 0)
        server = serve(node=node, **options)
        made.append(server)
        return server

    yield make
    for server in made:
        server.close()


@pytest.fixture
def roslibpy_client() -> Iterator[Callable[..., Any]]:
    roslibpy = pytest.importorskip('roslibpy', reason='roslibpy (the test extra) is missing')
    made: list[Any] = []

    def make(gateway: Any) -> Any:
        ros = roslibpy.Ros('127.0.0.1', gateway.port, transport='asyncio')
        ros.run(timeout=20)
        made.append(ros)
        return ros

    yield make
    for ros in made:
        ros.close()
        wait_for(lambda r=ros: not r.is_connected, 5.0)
        ros.terminate()


@pytest.fixture
def raw_client() -> Iterator[Callable[..., RawClient]]:
    made: list[RawClient] = []

    def make(gateway: Any, **options: Any) -> RawClient:
        client = RawClient(gateway.url, **options)
        made.append(client)
        return client

    yield make
    for client in made:
        client.close()


@pytest.fixture
def roslibjs() -> Iterator[Callable[[Any], RoslibClient]]:
    require_roslib()
    made: list[RoslibClient] = []

    def make(gateway: Any) -> RoslibClient:
        client = RoslibClient(gateway.url)
        made.append(client)
        return client

    yield make
    for client in made:
        client.close()
