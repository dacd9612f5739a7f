"""The rqt_graph picture: nodes (ellipses) and topics (boxes), publisher -> topic -> subscriber.

The model comes from the live graph view. zros and rmw_zenoh nodes own their endpoints; ROS
nodes behind a zenoh-bridge-ros2dds do not announce themselves, so their publishers and
subscribers appear under the bridge's node, as ``zros node info`` shows them. As rqt_graph
does by default, hidden names (a part starting with ``_``, e.g. action topics) and the debug
topics ``/rosout`` and ``/parameter_events`` are left out.
"""

from __future__ import annotations

import itertools
import os
from pathlib import Path
from typing import TYPE_CHECKING

from zros.keyexpr.kinds import EntityKind
from zros.plot.figure import new_figure
from zros.plot.graph_data import NODE, GraphModel, Layout, Measure, Vertex
from zros.plot.graph_layout import layout_graph

# matplotlib loads when a picture is drawn, the graph (Zenoh) when a live one is read
if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from zros.graph import Graph
    from zros.node import Node

#: topics rqt_graph's "hide debug" leaves out
DEBUG_TOPICS = frozenset({'/rosout', '/parameter_events'})
FONT_SIZE = 9.0
MARGIN = 12.0  #: points around the picture

NODE_COLORS = ('#e6eef8', '#3465a4')  #: face, edge
BRIDGE_COLORS = ('#fcefdc', '#c17d11')
TOPIC_COLORS = ('#ffffff', '#555753')
EDGE_COLOR = '#555753'


def is_hidden(name: str) -> bool:
    """Whether a ROS name is hidden (a part of it starts with ``_``)."""
    return any(part.startswith('_') for part in name.split('/'))


def graph_model(
    source: Node | Graph,
    *,
    namespace: str | None = None,
    hide_hidden: bool = True,
    hide_debug: bool = True,
    exclude: tuple[str, ...] = (),
) -> GraphModel:
    """The nodes, topics and edges the graph view of ``source`` knows now.

    Given a node, its own name is left out (a tool looking at the graph is not part of it) and
    topic names are read with its bridge namespace (``namespace`` otherwise, default ``/``).
    Bridged endpoints appear under their bridge's node, with the bridge's namespace.
    """
    from zros.graph import Graph  # noqa: PLC0415 (import zros.plot loads no Zenoh)

    if isinstance(source, Graph):
        graph = source
        namespace = namespace or '/'
    else:
        graph = source.graph
        namespace = namespace or source.scheme.namespace
        exclude = (*exclude, source.fully_qualified_name)

    def shown(name: str) -> bool:
        return not (hide_hidden and is_hidden(name))

    bridges = {bridge.zid: bridge for bridge in graph.bridges()}
    bridge_nodes = {bridge.node_name for bridge in bridges.values()}
    model = GraphModel()
    for name in graph.nodes():
        if name not in exclude and shown(name):
            model.add_node(name, bridge=name in bridge_nodes)
    for endpoint in graph.endpoints((EntityKind.PUBLISHER, EntityKind.SUBSCRIBER)):
        bridge = bridges.get(endpoint.zid) if endpoint.is_bridged else None
        if bridge is not None:
            owner = bridge.node_name
            topic = endpoint.ros_name(bridge.namespace or '/')
        else:  # a node's; or no owner known (yet) and no bridge: name the session
            owner = endpoint.node or f'(session {endpoint.zid[:8]})'
            topic = endpoint.ros_name(namespace)
        if owner in exclude or not shown(owner) or not shown(topic):
            continue
        if hide_debug and topic in DEBUG_TOPICS:
            continue
        model.add_node(owner, bridge=bridge is not None)
        if endpoint.kind is EntityKind.PUBLISHER:
            model.add_publisher(owner, topic, endpoint.type_name)
        else:
            model.add_subscriber(owner, topic, endpoint.type_name)
    return model


def font_measure(font_size: float = FONT_SIZE) -> Measure:
    """Label sizes in points, measured with the font the picture uses."""
    from matplotlib.backends.backend_agg import RendererAgg  # noqa: PLC0415 (lazy: matplotlib, only for a figure)
    from matplotlib.font_manager import FontProperties  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    renderer = RendererAgg(1, 1, 72)  # type: ignore[no-untyped-call]  # 72 dpi: pixel = point
    font = FontProperties(size=font_size)

    def measure(text: str) -> tuple[float, float]:
        width, height, _ = renderer.get_text_width_height_descent(  # type: ignore[no-untyped-call]  # untyped in matplotlib
            text, font, ismath=False
        )
        return float(width), float(height)

    return measure


def _edge_path(points: tuple[tuple[float, float], ...]) -> object:
    """Smooth curves through the points, leaving and entering each horizontally."""
    from matplotlib.path import Path as MplPath  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    vertices = [points[0]]
    codes = [MplPath.MOVETO]
    for (x0, y0), (x1, y1) in itertools.pairwise(points):
        half = (x1 - x0) / 2
        vertices += [(x0 + half, y0), (x1 - half, y1), (x1, y1)]
        codes += [MplPath.CURVE4] * 3
    return MplPath(vertices, codes)


def draw_graph(
    layout: Layout,
    model: GraphModel | None = None,
    *,
    font_size: float = FONT_SIZE,
    show: bool = False,
) -> Figure:
    """Draw a laid-out graph: one text per node and topic, a shape around each, the edges."""
    from matplotlib.patches import Ellipse, FancyArrowPatch, Rectangle  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    width = max(layout.width, 100.0) + 2 * MARGIN
    height = max(layout.height, 30.0) + 2 * MARGIN
    figure = new_figure(show, (width / 72, height / 72))
    figure.set_layout_engine('none')
    axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
    axes.set_axis_off()
    axes.set_xlim(-MARGIN, width - MARGIN)
    axes.set_ylim(height - MARGIN, -MARGIN)
    bridges = model.bridges if model is not None else set()
    for route in layout.routes:
        axes.add_patch(
            FancyArrowPatch(
                path=_edge_path(route.points),  # type: ignore[arg-type]  # a matplotlib Path
                arrowstyle='-|>,head_length=0.5,head_width=0.22',
                mutation_scale=14,
                color=EDGE_COLOR,
                linewidth=0.9,
                zorder=1,
            )
        )
    for vertex, box in layout.boxes.items():
        if vertex.kind == NODE:
            face, edge = BRIDGE_COLORS if vertex.name in bridges else NODE_COLORS
            shape: Ellipse | Rectangle = Ellipse((box.x, box.y), box.width, box.height)
        else:
            face, edge = TOPIC_COLORS
            shape = Rectangle((box.left, box.top), box.width, box.height)
        shape.set(facecolor=face, edgecolor=edge, linewidth=1.0, zorder=2)
        axes.add_patch(shape)
        axes.text(box.x, box.y, vertex.name, ha='center', va='center', fontsize=font_size, zorder=3)
    if not layout.boxes:
        axes.set_title('no nodes or topics', fontsize=font_size)
    return figure


def to_dot(model: GraphModel) -> str:
    """The model in Graphviz's DOT language (``dot -Tpng`` draws it where Graphviz exists)."""

    def ident(vertex: Vertex) -> str:
        return '"' + ('n:' if vertex.kind == NODE else 't:') + vertex.name + '"'

    lines = ['digraph ros_graph {', '  rankdir=LR;', '  node [fontname="sans-serif"];']
    for vertex in model.vertices():
        shape = 'ellipse' if vertex.kind == NODE else 'box'
        lines.append(f'  {ident(vertex)} [label="{vertex.name}", shape={shape}];')
    for source, target in sorted(model.edges):
        lines.append(f'  {ident(source)} -> {ident(target)};')
    lines.append('}')
    return '\n'.join(lines) + '\n'


def save_figure(figure: Figure, path: str | os.PathLike[str], dpi: float = 100) -> None:
    """Write a figure; an SVG keeps its texts as text (searchable, selectable)."""
    import matplotlib  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

    with matplotlib.rc_context({'svg.fonttype': 'none'}):
        figure.savefig(os.fspath(path), dpi=dpi)


def graph(
    source: Node | Graph | GraphModel,
    path: str | os.PathLike[str] | None = None,
    *,
    hide_hidden: bool = True,
    hide_debug: bool = True,
    show: bool = False,
) -> Figure:
    """The rqt_graph-like picture of the ROS graph; returns the figure.

    >>> zros.plot.graph(node, 'graph.svg')  # doctest: +SKIP

    ``source`` is a node (its graph view, itself left out), a ``zros.graph.Graph`` or a
    :class:`~zros.plot.graph_data.GraphModel`. The picture is what the view knows at the call: a
    program that just connected calls ``node.graph.refresh()`` first. ``path`` receives it as
    PNG, SVG or PDF by its extension, or as Graphviz DOT text for ``.dot``/``.gv``.
    ``hide_hidden`` leaves out hidden names, ``hide_debug`` ``/rosout`` and
    ``/parameter_events``; ``show`` opens a window.
    """
    if isinstance(source, GraphModel):
        model = source
    else:
        model = graph_model(source, hide_hidden=hide_hidden, hide_debug=hide_debug)
    layout = layout_graph(model, font_measure(FONT_SIZE), FONT_SIZE)
    figure = draw_graph(layout, model, show=show)
    if path is not None:
        if Path(path).suffix.lower() in ('.dot', '.gv'):
            Path(path).write_text(to_dot(model))
        else:
            save_figure(figure, path)
    if show:
        import matplotlib.pyplot as plt  # noqa: PLC0415 (lazy: matplotlib, only for a figure)

        plt.show()
    return figure
