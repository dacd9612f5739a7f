"""Following the graph: a thread that calls back when the graph changed (changes that come
together are handled once)."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from zros.graph import Graph
    from zros.node import Node

_log = logging.getLogger('zros.gateway')

#: seconds a graph watcher lets a burst of changes settle before looking
SETTLE = 0.05
#: seconds between a graph watcher's checks that it should stop
_POLL = 0.25


class GraphWatcher:
    """Calls ``on_change()`` on a thread of its own once at the start and after every change
    of the node's graph (a burst of changes settles for ``settle`` seconds first). Exceptions
    of ``on_change`` are logged and the watcher goes on."""

    def __init__(self, node: Node, on_change: Callable[[], object], settle: float = SETTLE) -> None:
        self._graph: Graph = node.graph
        self._on_change = on_change
        self._settle = settle
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._run, name='zros gateway graph', daemon=True)
        self._thread.start()

    def _run(self) -> None:
        graph = self._graph
        while not self._stopping.is_set():
            seen = graph.version
            try:
                self._on_change()
            except Exception:  # the graph thread outlives a bad graph entry or a closing session
                _log.exception('the gateway failed to follow the graph')
            changed = _changed_since(graph, seen)
            while not self._stopping.is_set() and not graph.wait_until(changed, _POLL):
                pass
            self._stopping.wait(self._settle)

    def close(self) -> None:
        """Stop watching (waits for a running ``on_change`` to finish)."""
        self._stopping.set()
        if threading.current_thread() is not self._thread:
            self._thread.join(5.0)


def _changed_since(graph: Graph, version: int) -> Callable[[], bool]:
    return lambda: graph.version != version
