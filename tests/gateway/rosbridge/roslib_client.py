"""roslib (roslibjs, the library web apps use) from npm, run by node, as a test client:
``../node/roslib_client.mjs`` driven over JSON lines."""

from __future__ import annotations

import itertools
from typing import Any

from tests.gateway.node_process import NODE_DIR, NodeProcess, require

SCRIPT = NODE_DIR / 'roslib_client.mjs'
TIMEOUT = 30.0


def require_roslib() -> None:
    """Skip where node, npm or the roslib package cannot be had (fail in CI)."""
    require('roslib')


class RoslibClient(NodeProcess):
    """One ``ROSLIB.Ros`` connected to ``url``."""

    def __init__(self, url: str) -> None:
        super().__init__(['node', str(SCRIPT), url])
        self._tags = itertools.count(1)

    def command(self, cmd: str, **args: Any) -> str:
        """Send a command; its tag (its events carry it)."""
        tag = f't{next(self._tags)}'
        self.send(cmd, tag=tag, **args)
        return tag

    def answer(self, tag: str, *kinds: str, timeout: float = TIMEOUT) -> dict[str, Any]:
        """The first event of ``kinds`` (or ``failure``) for a command."""
        return self.wait(lambda e: e.get('tag') == tag and e['ev'] in (*kinds, 'failure'), timeout)

    def messages(self, topic: str) -> list[Any]:
        """The messages received on ``topic`` so far."""
        return [e['msg'] for e in self.of('message') if e['topic'] == topic]

    def rosapi(self, what: str, *args: Any) -> Any:
        """Call a ``ROSLIB.Ros`` method of rosapi (``getTopics``...); its value."""
        event = self.answer(self.command('rosapi', what=what, args=list(args)), 'rosapi')
        assert event['ev'] == 'rosapi', event
        return event['value']
