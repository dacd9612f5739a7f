"""A robot and a laptop across a WAN in a box, for the congestion and priority tests and
``benchmarks/wan.py``: a router on the robot's side, the robot's node next to it, the laptop's
behind a :class:`DelayProxy` (50 ms each way, 10 Mbit/s), every Zenoh socket on the path sized
to the path's bandwidth-delay product (loopback's own buffers would hold seconds of data)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from dataclasses import dataclass, field

import zros
from tests.support.delay_proxy import DelayProxy
from zros.node import Node
from zros.transport import Router, Transport, TransportConfig, start_router

DELAY = 0.05  #: seconds each way
RATE = 10e6 / 8  #: bytes per second each way (10 Mbit/s)
BDP = int(RATE * 2 * DELAY)  #: the path's bandwidth-delay product (125 kB)
#: Zenoh's TCP socket buffers: the bandwidth-delay product (Linux doubles what it is given)
SIZED = {'transport/link/tcp/so_sndbuf': BDP // 2, 'transport/link/tcp/so_rcvbuf': BDP // 2}


def numbered_image(number: int, size: int = 900_000) -> zros.Message:
    """A mono8 image of ``size`` bytes of data whose frame id is ``number`` (which one
    arrived)."""
    image = zros.Message(
        'sensor_msgs/msg/Image', height=1, width=size, encoding='mono8', step=size,
        data=bytes(size),
    )  # fmt: skip
    image.header.frame_id = str(number)
    return image


@dataclass
class Wan:
    """The router, the proxy and the sessions made so far (closed by :func:`wan`)."""

    router: Router
    proxy: DelayProxy
    wire: str
    transports: list[Transport] = field(default_factory=list)
    nodes: list[Node] = field(default_factory=list)

    def node(self, name: str, *, remote: bool) -> Node:
        """A node on a session of its own: behind the proxy (``remote``) or by the router."""
        endpoint = self.proxy.endpoint if remote else self.router.endpoint
        transport = Transport(
            TransportConfig.create(connect=endpoint, shared_memory=False, zenoh=dict(SIZED))
        )
        self.transports.append(transport)
        node = Node(name, transport=transport, wire=self.wire)
        self.nodes.append(node)
        return node


@contextlib.contextmanager
def wan(
    wire: str = 'bridge', *, rate: float | None = RATE, large_payloads: bool = True
) -> Iterator[Wan]:
    """A router with path-sized socket buffers and a proxy to it (``rate`` None: no limit),
    with ``zros router``'s rule for large payloads unless ``large_payloads`` is False."""
    router = start_router(shared_memory=False, large_payloads=large_payloads, zenoh=dict(SIZED))
    host, port = router.endpoint.split('/')[1].rsplit(':', 1)
    try:
        with DelayProxy((host, int(port)), DELAY, rate=rate, buffer=BDP) as proxy:
            rig = Wan(router, proxy, wire)
            try:
                yield rig
            finally:
                for node in reversed(rig.nodes):
                    node.destroy()
                for transport in reversed(rig.transports):
                    transport.close()
    finally:
        router.close()
