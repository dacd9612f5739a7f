"""A layered layout of the ROS graph (nodes -> topics -> nodes, left to right), in pure Python.

rqt_graph draws with Graphviz's ``dot``: a layered (Sugiyama) layout. Graphviz needs its
system binary, which no wheel on PyPI provides, and networkx, the usual pure-Python choice,
has spring and spectral layouts but no layered one (its ``multipartite_layout`` takes layers
as given and orders nothing). A ROS graph has tens to a few hundred vertices, for which the
classic steps fit in this module:

1. **Cycles broken** with the greedy heuristic of Eades, Lin and Smyth (sinks to the end,
   sources to the front, else the vertex with the most outgoing minus incoming edges, ties to
   the one that publishes most: a robot's driver starts the picture, the commands it takes
   close the cycle): the edges that point backwards in that order are reversed for layering
   and drawn right to left.
2. **Layers** by longest path from the sources, then vertices with more outgoing than incoming
   edges move right next to their successors (publishers sit beside their topics).
3. **Order** inside layers by barycenter sweeps, down and up, keeping the order with the
   fewest crossings (edges over several layers pass through dummy vertices).
4. **Coordinates**: columns as wide as their widest label; in each column the vertical
   positions closest to the mean of their neighbours' that keep the order and the gaps, solved
   exactly by isotonic regression (pool adjacent violators), in sweeps.

Units are points (1/72 inch), y grows downwards. :func:`layout_graph` returns boxes and edge
routes as data, so tests check the geometry without drawing.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable

from zros.plot.graph_data import Box, GraphModel, Layout, Measure, Route, box_size, estimate_text

HORIZONTAL_GAP = 56.0  #: points between columns
VERTICAL_GAP = 14.0  #: points between two boxes of a column
DUMMY_GAP = 6.0  #: points between an edge passing through a column and its neighbours
SWEEPS = 12  #: rounds of barycenter ordering
PLACEMENTS = 8  #: rounds of vertical placement


# --- the steps ---------------------------------------------------------------------------------


def _acyclic_order(count: int, succ: list[set[int]], pred: list[set[int]]) -> list[int]:
    """Eades-Lin-Smyth: an order in which few edges point backwards."""
    out_degree = [len(s) for s in succ]
    in_degree = [len(p) for p in pred]
    alive = [True] * count
    left: list[int] = []
    right: list[int] = []

    def remove(v: int) -> None:
        alive[v] = False
        for w in succ[v]:
            in_degree[w] -= 1
        for u in pred[v]:
            out_degree[u] -= 1

    remaining = count
    while remaining:
        progress = True
        while progress:
            progress = False
            # sinks to the right, then sources to the left
            for degree, side in ((out_degree, right), (in_degree, left)):
                for v in range(count):
                    if alive[v] and degree[v] == 0:
                        side.append(v)
                        remove(v)
                        remaining -= 1
                        progress = True
        if remaining:
            # ties go to the vertex that feeds the most overall (a driver publishing sensors)
            chosen = max(
                (v for v in range(count) if alive[v]),
                key=lambda v: (out_degree[v] - in_degree[v], len(succ[v]) - len(pred[v]), -v),
            )
            left.append(chosen)
            remove(chosen)
            remaining -= 1
    return left + right[::-1]


def _layers(order: list[int], succ: list[set[int]], pred: list[set[int]]) -> list[int]:
    """Longest-path layers (``order`` is topological), then pulls toward successors."""
    layer = [0] * len(order)
    for v in order:
        if pred[v]:
            layer[v] = max(layer[u] for u in pred[v]) + 1
    for v in reversed(order):
        if succ[v] and len(succ[v]) > len(pred[v]):
            layer[v] = max(layer[v], min(layer[w] for w in succ[v]) - 1)
    low = min(layer, default=0)
    return [value - low for value in layer]


def _crossings(upper: dict[int, int], lower: dict[int, int], edges: list[tuple[int, int]]) -> int:
    """Crossings of the edges between two adjacent layers (an inversion count)."""
    pairs = sorted((upper[u], lower[v]) for u, v in edges)
    size = len(lower) + 1
    tree = [0] * (size + 1)
    crossings = 0
    for seen, (_, position) in enumerate(pairs):
        # edges seen so far that end below this one's end cross it
        index = position + 1
        at_most = 0
        while index > 0:
            at_most += tree[index]
            index -= index & -index
        crossings += seen - at_most
        index = position + 1
        while index <= size:
            tree[index] += 1
            index += index & -index
    return crossings


def _isotonic(targets: list[float]) -> list[float]:
    """The non-decreasing sequence closest to ``targets`` (least squares; pool adjacent
    violators)."""
    blocks: list[list[float]] = []  # [sum, count]
    for target in targets:
        blocks.append([target, 1.0])
        while len(blocks) > 1 and blocks[-2][0] / blocks[-2][1] > blocks[-1][0] / blocks[-1][1]:
            total, count = blocks.pop()
            blocks[-1][0] += total
            blocks[-1][1] += count
    result: list[float] = []
    for total, count in blocks:
        result += [total / count] * int(count)
    return result


class _Layered:
    """The working state: vertices 0..n-1 (real ones first, then dummies)."""

    def __init__(
        self, sizes: list[tuple[float, float]], dag: list[tuple[int, int]], layer: list[int]
    ):
        self.real = len(sizes)
        self.sizes = list(sizes)
        self.layer = list(layer)
        self.succ: list[list[int]] = [[] for _ in sizes]
        self.pred: list[list[int]] = [[] for _ in sizes]
        self.chains: dict[tuple[int, int], list[int]] = {}
        for u, v in dag:
            chain = [u]
            for step in range(self.layer[u] + 1, self.layer[v]):
                dummy = len(self.sizes)
                self.sizes.append((0.0, 0.0))
                self.layer.append(step)
                self.succ.append([])
                self.pred.append([])
                chain.append(dummy)
            chain.append(v)
            for a, b in itertools.pairwise(chain):
                self.succ[a].append(b)
                self.pred[b].append(a)
            self.chains[(u, v)] = chain
        depth = max(self.layer, default=-1) + 1
        self.rows: list[list[int]] = [[] for _ in range(depth)]

    # ordering

    def initial_order(self, order: list[int]) -> None:
        seen = [False] * len(self.sizes)
        for start in order:
            stack = [start]
            while stack:
                v = stack.pop()
                if seen[v]:
                    continue
                seen[v] = True
                self.rows[self.layer[v]].append(v)
                stack += sorted(self.succ[v], reverse=True)

    def positions(self) -> list[int]:
        where = [0] * len(self.sizes)
        for row in self.rows:
            for index, v in enumerate(row):
                where[v] = index
        return where

    def crossings(self) -> int:
        where = self.positions()
        total = 0
        for number in range(len(self.rows) - 1):
            upper = {v: where[v] for v in self.rows[number]}
            lower = {v: where[v] for v in self.rows[number + 1]}
            edges = [(u, w) for u in self.rows[number] for w in self.succ[u]]
            total += _crossings(upper, lower, edges)
        return total

    def _sort(self, number: int, neighbours: list[list[int]]) -> None:
        where = self.positions()
        row = self.rows[number]

        def key(item: tuple[int, int]) -> float:
            index, v = item
            near = neighbours[v]
            return sum(where[u] for u in near) / len(near) if near else float(index)

        self.rows[number] = [v for _, v in sorted(enumerate(row), key=key)]

    def order(self) -> int:
        best = [list(row) for row in self.rows]
        fewest = self.crossings()
        for _ in range(SWEEPS):
            if fewest == 0:
                break
            for number in range(1, len(self.rows)):
                self._sort(number, self.pred)
            for number in range(len(self.rows) - 2, -1, -1):
                self._sort(number, self.succ)
            found = self.crossings()
            if found < fewest:
                fewest = found
                best = [list(row) for row in self.rows]
        self.rows = best
        return fewest

    # coordinates

    def _gap(self, a: int, b: int) -> float:
        real = a < self.real and b < self.real
        return (self.sizes[a][1] + self.sizes[b][1]) / 2 + (VERTICAL_GAP if real else DUMMY_GAP)

    def _place(self, row: list[int], wanted: list[float], y: list[float]) -> None:
        offsets = [0.0]
        for a, b in itertools.pairwise(row):
            offsets.append(offsets[-1] + self._gap(a, b))
        fitted = _isotonic([want - offset for want, offset in zip(wanted, offsets, strict=True)])
        for v, value, offset in zip(row, fitted, offsets, strict=True):
            y[v] = value + offset

    def coordinates(self) -> tuple[list[float], list[float]]:
        y = [0.0] * len(self.sizes)
        for row in self.rows:
            self._place(row, [0.0] * len(row), y)
            if row:
                middle = (y[row[0]] + y[row[-1]]) / 2
                for v in row:
                    y[v] -= middle

        def sweep(numbers: Iterable[int], neighbours: Callable[[int], list[int]]) -> None:
            for number in numbers:
                row = self.rows[number]
                wanted = []
                for v in row:
                    near = neighbours(v)
                    wanted.append(sum(y[u] for u in near) / len(near) if near else y[v])
                self._place(row, wanted, y)

        rows = range(len(self.rows))
        for _ in range(PLACEMENTS):
            sweep(rows[1:], lambda v: self.pred[v])
            sweep(reversed(rows[:-1]), lambda v: self.succ[v])
        sweep(rows, lambda v: self.pred[v] + self.succ[v])
        x = [0.0] * len(self.sizes)
        left = 0.0
        for row in self.rows:
            width = max((self.sizes[v][0] for v in row), default=0.0) or 20.0
            for v in row:
                x[v] = left + width / 2
            left += width + HORIZONTAL_GAP
        return x, y


def layout_graph(
    model: GraphModel, measure: Measure | None = None, font_size: float = 9.0
) -> Layout:
    """Lay the model out left to right: publishers, their topics, the subscribers.

    ``measure(label) -> (width, height)`` in points sizes the labels (default: an estimate from
    the number of characters; the drawing measures with the font it uses).
    """
    measure = measure or estimate_text(font_size)
    vertices = model.vertices()
    index = {v: i for i, v in enumerate(vertices)}
    edges = sorted((index[a], index[b]) for a, b in model.edges if a != b)
    count = len(vertices)
    succ: list[set[int]] = [set() for _ in vertices]
    pred: list[set[int]] = [set() for _ in vertices]
    for u, v in edges:
        succ[u].add(v)
        pred[v].add(u)
    order = _acyclic_order(count, succ, pred)
    rank = {v: i for i, v in enumerate(order)}
    dag = sorted({(u, v) if rank[u] < rank[v] else (v, u) for u, v in edges})
    dag_succ: list[set[int]] = [set() for _ in vertices]
    dag_pred: list[set[int]] = [set() for _ in vertices]
    for u, v in dag:
        dag_succ[u].add(v)
        dag_pred[v].add(u)
    layers = _layers(order, dag_succ, dag_pred)
    sizes = [box_size(v, measure(v.name)) for v in vertices]
    state = _Layered(sizes, dag, layers)
    state.initial_order(order)
    crossings = state.order()
    x, y = state.coordinates()
    left = min((x[v] - state.sizes[v][0] / 2 for v in range(len(x))), default=0.0)
    top = min((y[v] - state.sizes[v][1] / 2 for v in range(len(y))), default=0.0)
    x = [value - left for value in x]
    y = [value - top for value in y]
    boxes = {
        vertex: Box(vertex, x[i], y[i], sizes[i][0], sizes[i][1], state.layer[i])
        for i, vertex in enumerate(vertices)
    }
    routes = []
    for u, v in edges:
        backwards = rank[u] > rank[v]
        chain = state.chains[(v, u)] if backwards else state.chains[(u, v)]
        if backwards:
            chain = chain[::-1]
        source, target = boxes[vertices[u]], boxes[vertices[v]]
        if backwards:
            start = (source.left, source.y)
            end = (target.right, target.y)
        else:
            start = (source.right, source.y)
            end = (target.left, target.y)
        middle = [(x[d], y[d]) for d in chain[1:-1]]
        if backwards and not middle:  # apart from a forward edge between the same two
            middle = [((start[0] + end[0]) / 2, (start[1] + end[1]) / 2 + VERTICAL_GAP)]
        routes.append(Route(source.vertex, target.vertex, (start, *middle, end), backwards))
    width = max((b.right for b in boxes.values()), default=0.0)
    height = max((b.bottom for b in boxes.values()), default=0.0)
    height = max([height] + [py for r in routes for _, py in r.points])
    return Layout(boxes, routes, math.ceil(width), math.ceil(height), crossings)
