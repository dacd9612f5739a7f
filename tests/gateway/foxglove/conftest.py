"""Fixtures of the gateway tests: Foxglove gateways on the test router, and real clients.

* ``foxglove_client``: ``make(url, ca=None, origin=None)`` -> a :class:`FoxgloveClient`
  (``@foxglove/ws-protocol`` run by node), once offering the library's subprotocol
  (``foxglove.websocket.v1``, as Lichtblick does) and once only the SDK's (``foxglove.sdk.v1``,
  as the Foxglove app does); skips where node or npm is missing (fails instead with
  ZROS_TEST_NODE_REQUIRED=1).
* ``gateway``: ``make(**serve_options)`` -> a running ``FoxgloveGateway`` on its own node
  (of the module's ``zros_wire``), on a free port.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tests.gateway.foxglove.client import LIBRARY_PROTOCOL, SDK_PROTOCOL, FoxgloveClient
from tests.gateway.node_process import require


@pytest.fixture(params=[LIBRARY_PROTOCOL, SDK_PROTOCOL])
def foxglove_client(request: pytest.FixtureRequest) -> Iterator[Callable[..., FoxgloveClient]]:
    require()
    made: list[FoxgloveClient] = []

    def make(url: str, ca: str | None = None, origin: str | None = None) -> FoxgloveClient:
        client = FoxgloveClient(url, ca, protocol=request.param, origin=origin)
        made.append(client)
        return client

    yield make
    for client in made:
        client.close()


@pytest.fixture
def gateway(zros_node: Callable[..., Any]) -> Iterator[Callable[..., Any]]:
    pytest.importorskip('foxglove', reason='the Foxglove SDK (the foxglove extra) is missing')
    from zros.gateway.foxglove.server import serve

    made: list[Any] = []

    def make(**options: Any) -> Any:
        node = options.pop('node', None) or zros_node(
            'zros_foxglove', enable_rosout=False, start_parameter_services=False
        )
        options.setdefault('port', 0)
        options.setdefault('sim_time', False)
        server = serve(node=node, **options)
        made.append(server)
        return server

    yield make
    for server in made:
        server.close()
