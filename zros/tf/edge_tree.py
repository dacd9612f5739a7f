"""The tree a buffer holds: each frame's edge to its parent, every frame's name, and the
chains found between two frames, kept until the tree changes. The buffer locks around it."""

from __future__ import annotations

from zros.tf import checks
from zros.tf.cache import EdgeCache
from zros.tf.checks import Authority
from zros.tf.tree import Chain, ancestors, find_chain

#: frames a live buffer takes before refusing new ones (a flood of names must not grow it)
MAX_FRAMES = 10_000
#: transforms one live edge keeps, whatever its rate
MAX_EDGE_LENGTH = 100_000
#: chains kept between two frames before the oldest are forgotten
MAX_CHAINS = 10_000


class EdgeTree:
    """Edges by child frame, frame names and found chains; ``cache_time`` (ns, None: keep
    everything) is how long a moving edge keeps its transforms."""

    def __init__(self, cache_time: int | None, rejections: checks.Rejections) -> None:
        self.cache_time = cache_time
        self.edges: dict[str, EdgeCache] = {}
        self.names: set[str] = set()
        self._rejections = rejections
        self._version = 0
        self._chains: dict[tuple[str, str], Chain] = {}

    def changed(self) -> None:
        """The tree changed: chains found before are found anew."""
        self._version += 1
        self._chains.clear()

    def clear(self) -> None:
        """Forget every moving edge; static edges and the frames' names stay (tf2's clear)."""
        for child in [child for child, edge in self.edges.items() if not edge.static]:
            del self.edges[child]
        self.changed()

    def edge_for(
        self, parent: str, child: str, stamp: int, authority: Authority, static: bool
    ) -> EdgeCache | None:
        """The edge to insert into (made if new); None when the transform is refused."""
        edge = self.edges.get(child)
        if edge is not None and edge.static != static:
            # a static frame turned moving, or back: tf2 replaces its cache with one of the
            # new kind, forgetting the old one (parent included)
            del self.edges[child]
            self.changed()
        elif edge is not None:
            if edge.parent == parent:
                return edge
            expired = (
                not edge.static
                and self.cache_time is not None
                and stamp - edge.newest > self.cache_time
            )
            if not expired:
                message = checks.two_parents(child, parent, authority, edge.parent, edge.authority)
                self._rejections.report(checks.TWO_PARENTS, authority, child, message)
                return None
        chain = ancestors(self.edges, parent)
        if child in chain:
            loop = ' -> '.join([child, *chain[: chain.index(child) + 1]])
            message = checks.loop(child, parent, authority, loop)
            self._rejections.report(checks.LOOP, authority, child, message)
            return None
        full = self.cache_time is not None and len(self.edges) >= MAX_FRAMES
        if full and child not in self.edges:
            message = checks.too_many_frames(child, authority, MAX_FRAMES)
            self._rejections.report(checks.TOO_MANY_FRAMES, authority, child, message)
            return None
        edge = EdgeCache(
            parent,
            static=static,
            max_age=self.cache_time,
            max_length=None if self.cache_time is None else MAX_EDGE_LENGTH,
        )
        self.edges[child] = edge
        self.names.add(child)
        self.names.add(parent)
        self.changed()
        return edge

    def chain(self, target: str, source: str) -> Chain:
        """The chain from ``source`` to ``target`` (LookupException, ConnectivityException)."""
        key = (target, source)
        chain = self._chains.get(key)
        if chain is None:
            chain = find_chain(self.edges, self.names, target, source, self._version)
            if len(self._chains) > MAX_CHAINS:
                self._chains.clear()
            self._chains[key] = chain
        return chain

    def check_known(self, target: str, source: str) -> None:
        """LookupException unless ``source`` (the same frame as ``target``) is known."""
        if source not in self.names:
            find_chain(self.edges, self.names, target, source, self._version)
