"""The gateways' defaults that their ``serve`` functions and the command line share: ports and
per-client limits. It imports nothing, so ``zros foxglove --help`` reads them without loading a
gateway."""

from __future__ import annotations

#: foxglove_bridge's port
FOXGLOVE_PORT = 8765
#: rosbridge_server's port
ROSBRIDGE_PORT = 9090
#: 32 MiB: what one client of a gateway may hold queued before its oldest messages drop
CLIENT_BUFFER = 32 * 1024**2
#: connections a gateway serves at once unless told (its handshakes included)
MAX_CLIENTS = 100
