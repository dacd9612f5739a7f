"""The tree a buffer holds: each frame's edge to its parent, every frame's name, and the
chains found between two frames, kept until the tree changes. The buffer locks around it.

A moving frame may change parent over time, as in tf2: it then keeps an edge per parent
(``parents``), the one with the newest data is its edge in the tree (``edges``), and a lookup
whose chain meets such a frame walks the tree as it was at the lookup's time
(:mod:`zros.tf.parents`).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping

from zros.tf import checks
from zros.tf.cache import EdgeCache
from zros.tf.checks import Authority
from zros.tf.errors import ConnectivityException
from zros.tf.parents import EdgesAt
from zros.tf.tree import Chain, ancestors, find_chain

_log = logging.getLogger('zros.tf')

#: frames a live buffer takes before refusing new ones (a flood of names must not grow it)
MAX_FRAMES = 10_000
#: transforms one live edge keeps, whatever its rate
MAX_EDGE_LENGTH = 100_000
#: chains kept between two frames before the oldest are forgotten
MAX_CHAINS = 10_000
#: parents one live frame keeps edges for (a frame handed on and on); the stalest go first
MAX_PARENTS = 16


class EdgeTree:
    """Edges by child frame, frame names and found chains; ``cache_time`` (ns, None: keep
    everything) is how long a moving edge keeps its transforms."""

    def __init__(self, cache_time: int | None, rejections: checks.Rejections) -> None:
        self.cache_time = cache_time
        self.edges: dict[str, EdgeCache] = {}
        #: the frames that changed parent: an edge per parent (the one in ``edges`` among them)
        self.parents: dict[str, dict[str, EdgeCache]] = {}
        self.names: set[str] = set()
        self._told: set[tuple[str, str]] = set()
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
        self.parents.clear()  # only moving frames change parent
        self.changed()

    def _forget(self, child: str) -> None:
        del self.edges[child]
        self.parents.pop(child, None)
        self.changed()

    def edge_for(
        self, parent: str, child: str, stamp: int, authority: Authority, static: bool
    ) -> EdgeCache | None:
        """The edge to insert into (made if new); None when the transform is refused. Call
        :meth:`inserted` once the transform is in."""
        edge = self.edges.get(child)
        if edge is not None and (edge.static != static or (static and edge.parent != parent)):
            # a static frame turned moving, or back, or took a new parent: tf2 replaces its
            # cache with one of the new kind (a static cache holds one transform, parent and all)
            self._forget(child)
        elif edge is not None:
            if edge.parent == parent:
                return edge
            known = self.parents.get(child)
            if known is not None and parent in known:
                return known[parent]
            if self._closes_loop(child, parent, authority):
                return None
            if self._too_many_names(parent):  # a flood of new parents for one frame
                message = checks.too_many_frames(child, authority, MAX_FRAMES)
                self._rejections.report(checks.TOO_MANY_FRAMES, authority, child, message)
                return None
            # a moving frame changes parent (tf2 keeps the parent with every sample)
            new = self._new_edge(parent, child, static=False)
            self.parents.setdefault(child, {edge.parent: edge})[parent] = new
            self._tell_new_parent(child, parent, edge.parent, authority)
            return new
        if self._closes_loop(child, parent, authority):
            return None
        full = self.cache_time is not None and len(self.edges) >= MAX_FRAMES
        if full and child not in self.edges:
            message = checks.too_many_frames(child, authority, MAX_FRAMES)
            self._rejections.report(checks.TOO_MANY_FRAMES, authority, child, message)
            return None
        edge = self._new_edge(parent, child, static=static)
        self.edges[child] = edge
        self.changed()
        return edge

    def inserted(self, child: str, edge: EdgeCache) -> None:
        """``edge`` of ``child`` took transforms: for a frame that changed parent, the edge with
        the newest data becomes its edge in the tree, and edges past the window go."""
        known = self.parents.get(child)
        if known is None:
            return
        current = self.edges[child]
        if edge is not current and len(edge) and (not len(current) or edge.newest > current.newest):
            self.edges[child] = current = edge
            self.changed()
        newest = current.newest
        if self.cache_time is not None:
            others = sorted(  # the freshest first: they are kept
                (other for other in known.values() if other is not current),
                key=lambda other: other.newest if len(other) else -1,
                reverse=True,
            )
            room = MAX_PARENTS - 1
            for other in others:
                if not len(other) or other.newest < newest - self.cache_time or room <= 0:
                    del known[other.parent]
                else:
                    room -= 1
        if len(known) == 1:
            del self.parents[child]

    def _too_many_names(self, parent: str) -> bool:
        """Whether a live buffer holds as many frame names as its frames can have (a child and
        a parent each) and ``parent`` would be one more."""
        full = self.cache_time is not None and len(self.names) >= 2 * MAX_FRAMES
        return full and parent not in self.names

    def _new_edge(self, parent: str, child: str, *, static: bool) -> EdgeCache:
        self.names.add(child)
        self.names.add(parent)
        return EdgeCache(
            parent,
            static=static,
            max_age=self.cache_time,
            max_length=None if self.cache_time is None else MAX_EDGE_LENGTH,
        )

    def _closes_loop(self, child: str, parent: str, authority: Authority) -> bool:
        chain = ancestors(self.edges, parent)
        if child not in chain:
            return False
        loop = ' -> '.join([child, *chain[: chain.index(child) + 1]])
        message = checks.loop(child, parent, authority, loop)
        self._rejections.report(checks.LOOP, authority, child, message)
        return True

    def _tell_new_parent(self, child: str, parent: str, old: str, authority: Authority) -> None:
        if (child, parent) in self._told or len(self._told) >= checks.MAX_TOLD:
            return
        self._told.add((child, parent))
        _log.info(
            'frame "%s" takes the parent "%s" (from authority "%s"); it had "%s": lookups use '
            'the parent it had at their time, as tf2 does',
            child,
            parent,
            authority,
            old,
        )

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

    def fixed_chain(self, target: str, source: str) -> Chain | None:
        """The chain from ``source`` to ``target`` (LookupException, ConnectivityException), or
        None when it depends on the time: it meets a frame that changed parent, or joins the
        two frames only through a parent such a frame had (:meth:`chain_at` then)."""
        if not self.parents:
            return self.chain(target, source)
        try:
            chain = self.chain(target, source)
        except ConnectivityException:
            return None
        if any(child in self.parents for child, _ in chain.edges):
            return None
        return chain

    def chain_at(self, target: str, source: str, stamp: int) -> Chain:
        """The chain from ``source`` to ``target`` as the tree was at ``stamp`` (not kept)."""
        edges: Mapping[str, EdgeCache] = EdgesAt(self.edges, self.parents, stamp)
        return find_chain(edges, self.names, target, source, self._version)

    def reachable(self, frames: tuple[str, ...]) -> list[EdgeCache]:
        """Every edge above ``frames`` under any parent they or their ancestors ever had."""
        found: dict[int, EdgeCache] = {}
        todo = list(frames)
        seen: set[str] = set()
        while todo:
            frame = todo.pop()
            if frame in seen:
                continue
            seen.add(frame)
            known = self.parents.get(frame)
            edges = known.values() if known is not None else [self.edges.get(frame)]
            for edge in edges:
                if edge is not None:
                    found[id(edge)] = edge
                    todo.append(edge.parent)
        return list(found.values())

    def check_known(self, target: str, source: str) -> None:
        """LookupException unless ``source`` (the same frame as ``target``) is known."""
        if source not in self.names:
            find_chain(self.edges, self.names, target, source, self._version)
