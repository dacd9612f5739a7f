"""A Foxglove bag server in a process of its own, played to its end by a real Foxglove client
subscribed to every channel, and the peak memory of the server's process and of its child
(the Foxglove front, which relays the WebSocket bytes).

Shared by tests/gateway/foxglove/test_bag_memory.py and benchmarks/bag_server.py.
"""

from __future__ import annotations

import json
import sys
import tempfile
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from tests.gateway.foxglove.client import SDK_PROTOCOL, FoxgloveClient
from zros.testing import PeakMemory, peak_memory, wait_for

#: the playback speed asked for: as fast as the server sends
SPEED = 1e6

#: the playback state that says the bag played to its end
ENDED = 3

#: the server: its memory once listening, its address written to a file (renamed into place,
#: so the parent never reads half of it), then played until every message went out (and
#: ``extra`` more, those of the seeks)
SERVE = """
import json, os, sys, time
from pathlib import Path
from zros.gateway.foxglove.bag_server import BagGateway
from zros.gateway.foxglove.sdk import ServerOptions
from zros.testing import _resident, wait_for
bag, address, timeout, extra = sys.argv[1], Path(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
gateway = BagGateway(bag, ServerOptions(port=0))
idle = _resident(os.getpid())
address.with_suffix('.tmp').write_text(gateway.url)
address.with_suffix('.tmp').rename(address)
total = gateway.source.message_count + extra
wait_for(lambda: gateway.published > 0, timeout)
begin = time.perf_counter()
wait_for(lambda: gateway.published >= total, timeout)
seconds = time.perf_counter() - begin
published = gateway.published
gateway.close()
print(json.dumps({'idle': idle, 'published': published, 'seconds': seconds}))
"""


@dataclass(frozen=True)
class Played:
    """What playing a bag through a server in a process of its own cost that process."""

    peak: PeakMemory  #: its peak anonymous and file-mapped memory, and its children's
    idle_anonymous: int  #: its anonymous memory once listening, before playing
    idle_file: int  #: and its file-mapped memory then
    published: int  #: messages the server sent
    seconds: float  #: from its first message sent to its last
    received: int  #: messages the client received (the rest were dropped for it)


def play_through(
    path: Path, topics: list[str], timeout: float = 300.0, seeks: Sequence[tuple[int, int]] = ()
) -> Played:
    """Serve ``path`` in a process of its own; a Foxglove client subscribes to ``topics`` and
    plays the bag at :data:`SPEED` to its end, then from each of ``seeks`` (a time, and how
    many messages lie from it to the end) to the end again."""
    with tempfile.TemporaryDirectory() as folder:
        address = Path(folder) / 'address'
        found: list[PeakMemory] = []
        extra = sum(count for _, count in seeks)
        argv = [sys.executable, '-c', SERVE, str(path), str(address), str(timeout), str(extra)]
        server = threading.Thread(
            target=lambda: found.append(peak_memory(argv, timeout=timeout, children=True))
        )
        server.start()
        wait_for(lambda: address.exists() or not server.is_alive(), timeout)
        if not address.exists():
            server.join()
            raise AssertionError(f'the server did not start: {found[0].stderr if found else ""}')
        client = FoxgloveClient(address.read_text(), protocol=SDK_PROTOCOL)
        try:
            subscriptions = [client.subscribe(topic, quiet=True) for topic in topics]
            start = client.mark()
            client.send('playback', command=0, speed=SPEED, seek=None, requestId='play')
            for seek, _ in seeks:
                client.wait(
                    lambda e: e['ev'] == 'playbackState' and e['status'] == ENDED, timeout, start
                )
                start = client.mark()
                client.send('playback', command=0, speed=SPEED, seek=seek, requestId=f'{seek}')
            server.join(timeout)
            counts = client.stats()
        finally:
            client.close()
    (peak,) = found
    assert peak.returncode == 0, peak.stderr
    report = json.loads(peak.stdout.splitlines()[-1])
    return Played(
        peak,
        *report['idle'],
        report['published'],
        report['seconds'],
        sum(counts[str(s)]['count'] for s in subscriptions),
    )
