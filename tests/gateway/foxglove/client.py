"""A real Foxglove client for the tests: ``@foxglove/ws-protocol`` from npm, run by node.

``../node/client.js`` wraps the library in JSON lines (commands in, events out);
:class:`FoxgloveClient` is its Python face (a :class:`~tests.gateway.node_process.NodeProcess`).
"""

from __future__ import annotations

import base64
import os
from pathlib import Path
from typing import Any

from tests.gateway.node_process import NODE_DIR, TIMEOUT, NodeProcess

SCRIPT = NODE_DIR / 'client.js'


#: the subprotocol ``@foxglove/ws-protocol`` offers (Lichtblick, the library's README)
LIBRARY_PROTOCOL = 'foxglove.websocket.v1'
#: the one the Foxglove SDK's servers and the Foxglove app use
SDK_PROTOCOL = 'foxglove.sdk.v1'


class FoxgloveClient(NodeProcess):
    """One Foxglove client connected to ``url`` (``node/client.js``, or a ``script`` speaking
    the same JSON lines). It offers the library's own subprotocol unless ``protocol`` names
    another; ``origin``: it sends that ``Origin``, as a browser's page would."""

    def __init__(
        self,
        url: str,
        ca: str | os.PathLike[str] | None = None,
        script: Path = SCRIPT,
        protocol: str | None = None,
        origin: str | None = None,
    ) -> None:
        args = ['node', str(script), url]
        for flag, value in (('--ca', ca), ('--protocol', protocol), ('--origin', origin)):
            if value is not None:
                args += [flag, str(value)]
        super().__init__(args)

    # --- what tests do -----------------------------------------------------------------------

    def server_info(self) -> dict[str, Any]:
        return self.wait(lambda e: e['ev'] == 'serverInfo')['info']

    def channels(self) -> dict[str, dict[str, Any]]:
        """Advertised channels by topic (minus those unadvertised)."""
        found: dict[int, dict[str, Any]] = {}
        for event in list(self.events):
            if event['ev'] == 'advertise':
                found.update({c['id']: c for c in event['channels']})
            elif event['ev'] == 'unadvertise':
                for channel_id in event['channelIds']:
                    found.pop(channel_id, None)
        return {c['topic']: c for c in found.values()}

    def channel(self, topic: str, timeout: float = TIMEOUT) -> dict[str, Any]:
        """The channel of ``topic``, once advertised."""
        self.wait(lambda e: topic in self.channels(), timeout)
        return self.channels()[topic]

    def subscribe(
        self, topic: str, timeout: float = TIMEOUT, quiet: bool = False, latency: bool = False
    ) -> int:
        """Subscribe to the channel of ``topic``; its subscription id. ``quiet``: its messages
        are counted from the first (:meth:`stats`), not reported; ``latency``: with their delays.

        The SDK records a channel as advertised to a client just after sending the
        advertisement, so a client that subscribes at once can be refused ("Unknown channel
        ID"). A subscription to a channel that cannot exist is refused too, in order: once
        that refusal arrived, the real subscription's answer (if any) is in, and a refused
        one is sent again.
        """
        for fence in range(2**31, 2**31 + 10):
            channel = self.channel(topic, timeout)
            start = self.mark()
            self.send('subscribe', channelId=channel['id'], quiet=quiet, latency=latency)
            event = self.wait(lambda e: e['ev'] == 'subscribed', start=start)
            self.send('subscribe', channelId=fence)
            self.wait(lambda e, f=fence: self._refused(e, f), start=start)
            if not any(self._refused(e, channel['id']) for e in self.events[start:]):
                return int(event['subscriptionId'])
        raise AssertionError(f'the server kept refusing the channel of {topic}')

    @staticmethod
    def _refused(event: dict[str, Any], channel: int) -> bool:
        return (
            event['ev'] == 'status'
            and event['status']['message'] == f'Unknown channel ID: {channel}'
        )

    def messages(self, subscription: int) -> list[bytes]:
        return [
            base64.b64decode(e['data'])
            for e in self.of('message')
            if e['subscriptionId'] == subscription
        ]

    def last(self, subscription: int) -> bytes | None:
        """The newest message of a subscription (None before the first)."""
        with self._arrived:
            for event in reversed(self.events):
                if event['ev'] == 'message' and event['subscriptionId'] == subscription:
                    return base64.b64decode(event['data'])
        return None

    def count(self, subscription: int) -> int:
        """How many messages of a subscription arrived (without decoding them)."""
        with self._arrived:
            return sum(
                1
                for e in self.events
                if e['ev'] == 'message' and e['subscriptionId'] == subscription
            )

    def wait_messages(
        self, subscription: int, count: int = 1, timeout: float = TIMEOUT
    ) -> list[bytes]:
        self.wait(lambda e: self.count(subscription) >= count, timeout)
        return self.messages(subscription)

    def advertise(self, topic: str, encoding: str, schema_name: str, **extra: Any) -> int:
        start = self.mark()
        self.send('advertise', topic=topic, encoding=encoding, schemaName=schema_name, **extra)
        event = self.wait(lambda e: e['ev'] == 'advertised' and e['topic'] == topic, start=start)
        return int(event['channelId'])

    def publish(self, channel: int, data: bytes) -> None:
        self.send('publish', channelId=channel, data=base64.b64encode(data).decode())

    def services(self) -> dict[str, dict[str, Any]]:
        found: dict[str, dict[str, Any]] = {}
        for event in list(self.events):
            if event['ev'] == 'advertiseServices':
                found.update({s['name']: s for s in event['services']})
            elif event['ev'] == 'unadvertiseServices':
                found = {n: s for n, s in found.items() if s['id'] not in event['serviceIds']}
        return found

    def call_service(self, name: str, data: bytes, encoding: str = 'cdr') -> dict[str, Any]:
        """Call a service; the response or failure event."""
        self.wait(lambda e: name in self.services())
        service = self.services()[name]
        call = next(self._ids)
        start = self.mark()
        self.send(
            'callService',
            serviceId=service['id'],
            callId=call,
            encoding=encoding,
            data=base64.b64encode(data).decode(),
        )
        return self.wait(
            lambda e: (
                e['ev'] in ('serviceCallResponse', 'serviceCallFailure') and e['callId'] == call
            ),
            start=start,
        )

    def get_parameters(self, names: list[str], timeout: float = TIMEOUT) -> list[dict[str, Any]]:
        request = f'get-{next(self._ids)}'
        start = self.mark()
        self.send('getParameters', names=names, id=request)
        event = self.wait(
            lambda e: e['ev'] == 'parameterValues' and e.get('id') == request, timeout, start
        )
        return list(event['parameters'])

    def set_parameters(self, parameters: list[dict[str, Any]]) -> list[dict[str, Any]]:
        request = f'set-{next(self._ids)}'
        start = self.mark()
        self.send('setParameters', parameters=parameters, id=request)
        event = self.wait(
            lambda e: e['ev'] == 'parameterValues' and e.get('id') == request, start=start
        )
        return list(event['parameters'])

    def fetch_asset(self, uri: str) -> dict[str, Any]:
        request = next(self._ids)
        start = self.mark()
        self.send('fetchAsset', uri=uri, requestId=request)
        return self.wait(
            lambda e: e['ev'] == 'fetchAssetResponse' and e['requestId'] == request, start=start
        )

    def stats(self) -> dict[str, dict[str, Any]]:
        start = self.mark()
        self.send('stats')
        return dict(self.wait(lambda e: e['ev'] == 'stats', start=start)['counts'])


def image(width: int, height: int, seq: int) -> Any:
    """An rgb8 ``sensor_msgs/Image`` whose pixels and stamp say ``seq``."""
    import numpy as np

    import zros

    data = np.full(width * height * 3, seq % 251, dtype=np.uint8)
    return zros.Message(
        'sensor_msgs/msg/Image',
        header={'frame_id': 'camera', 'stamp': {'sec': seq}},
        height=height,
        width=width,
        encoding='rgb8',
        step=width * 3,
        data=data,
    )


def changes_followed(client: FoxgloveClient, node: Any, name: str) -> None:
    """Change parameter ``name`` of ``node`` (to 1000, 1001...) until ``client`` is told of a
    change: the gateway's subscription to /parameter_events is matched from then on."""
    from zros.testing import wait_for

    full = f'/{node.get_name()}.{name}'
    kind = type(node.get_parameter(name))
    values = iter(range(1000, 1_000_000))
    start = client.mark()

    def told() -> bool:
        node.set_parameter(name, kind(next(values)))
        return any(
            p['name'] == full
            for e in client.events[start:]
            if e['ev'] == 'parameterValues' and 'id' not in e
            for p in e['parameters']
        )

    assert wait_for(told, TIMEOUT), f'no change of {full} reached the client'
