"""The graph picture as data: vertices, the model of the graph, and its laid-out boxes and routes.

:mod:`zros.plot.graph_layout` turns a :class:`GraphModel` into a :class:`Layout`;
:mod:`zros.plot.graph_picture` draws it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

NODE = 'node'
TOPIC = 'topic'


@dataclass(frozen=True, order=True)
class Vertex:
    """A node (``kind='node'``) or a topic (``kind='topic'``) of the picture."""

    kind: str
    name: str


@dataclass
class GraphModel:
    """What the graph picture shows: nodes, topics, and edges publisher -> topic -> subscriber."""

    nodes: set[str] = field(default_factory=set)
    topics: dict[str, set[str]] = field(default_factory=dict)  #: name -> types
    edges: set[tuple[Vertex, Vertex]] = field(default_factory=set)
    bridges: set[str] = field(default_factory=set)  #: nodes that stand for a bridge's ROS side

    def add_node(self, name: str, bridge: bool = False) -> Vertex:
        """Add a node (once); ``bridge`` marks a bridge's node."""
        self.nodes.add(name)
        if bridge:
            self.bridges.add(name)
        return Vertex(NODE, name)

    def add_topic(self, name: str, type_name: str | None = None) -> Vertex:
        """Add a topic (once), with a type."""
        types = self.topics.setdefault(name, set())
        if type_name:
            types.add(type_name)
        return Vertex(TOPIC, name)

    def add_publisher(self, node: str, topic: str, type_name: str | None = None) -> None:
        """``node`` publishes ``topic``: an edge node -> topic."""
        self.edges.add((self.add_node(node), self.add_topic(topic, type_name)))

    def add_subscriber(self, node: str, topic: str, type_name: str | None = None) -> None:
        """``node`` subscribes to ``topic``: an edge topic -> node."""
        self.edges.add((self.add_topic(topic, type_name), self.add_node(node)))

    def vertices(self) -> list[Vertex]:
        """Every node and topic, sorted by kind, then name."""
        return sorted(
            [Vertex(NODE, n) for n in self.nodes] + [Vertex(TOPIC, t) for t in self.topics]
        )


@dataclass(frozen=True)
class Box:
    """Where a vertex is drawn: its center, size (points) and layer (column)."""

    vertex: Vertex
    x: float
    y: float
    width: float
    height: float
    layer: int

    @property
    def left(self) -> float:
        """x of the left side."""
        return self.x - self.width / 2

    @property
    def right(self) -> float:
        """x of the right side."""
        return self.x + self.width / 2

    @property
    def top(self) -> float:
        """y of the top side (y grows downwards)."""
        return self.y - self.height / 2

    @property
    def bottom(self) -> float:
        """y of the bottom side."""
        return self.y + self.height / 2

    def overlaps(self, other: Box) -> bool:
        """Whether the two boxes share any area."""
        return (
            self.left < other.right
            and other.left < self.right
            and self.top < other.bottom
            and other.top < self.bottom
        )


@dataclass(frozen=True)
class Route:
    """The path of one edge, from the side of its source to the side of its target."""

    source: Vertex
    target: Vertex
    points: tuple[tuple[float, float], ...]
    reversed: bool  #: drawn right to left: the edge closes a cycle


@dataclass
class Layout:
    """The laid-out picture: a box per vertex, a route per edge, the size of it all."""

    boxes: dict[Vertex, Box]
    routes: list[Route]
    width: float
    height: float
    crossings: int  #: edge crossings between adjacent columns


Measure = Callable[[str], tuple[float, float]]


def estimate_text(font_size: float) -> Measure:
    """A text measure without fonts: 0.62 em per character, 1.2 em high."""
    return lambda text: (0.62 * font_size * len(text), 1.2 * font_size)


def box_size(vertex: Vertex, text: tuple[float, float]) -> tuple[float, float]:
    """The size of a vertex's shape around its label: an ellipse for a node, a box for a topic."""
    width, height = text
    if vertex.kind == NODE:
        return max(width * 1.25 + 12, 48.0), height * 1.7 + 10
    return max(width + 14, 32.0), height + 12
