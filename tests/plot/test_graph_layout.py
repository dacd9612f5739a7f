"""The layered layout as data (boxes, routes), and the picture drawn from it."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import matplotlib.image
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.patches import Ellipse, FancyArrowPatch, Rectangle

from zros.plot import GraphModel, Layout, Vertex, draw_graph, graph, layout_graph, to_dot
from zros.plot.graph_data import NODE, TOPIC
from zros.plot.graph_picture import BRIDGE_COLORS, NODE_COLORS, font_measure


def scene() -> GraphModel:
    """A talker, a relay, a cycle a -> /x -> b -> /y -> a, a bridge, a lonely node."""
    model = GraphModel()
    model.add_publisher('/talker', '/chatter', 'std_msgs/msg/String')
    model.add_subscriber('/listener', '/chatter')
    model.add_subscriber('/relay', '/chatter')
    model.add_publisher('/relay', '/relayed')
    model.add_subscriber('/listener', '/relayed')
    model.add_publisher('/a', '/x')
    model.add_subscriber('/b', '/x')
    model.add_publisher('/b', '/y')
    model.add_subscriber('/a', '/y')
    model.add_publisher('/teleop', '/cmd_vel')
    model.add_subscriber('/zenoh_bridge_ros2dds', '/cmd_vel')
    model.bridges.add('/zenoh_bridge_ros2dds')
    model.add_node('/lonely')
    return model


def check_geometry(model: GraphModel, layout: Layout) -> None:
    """No two boxes overlap; forward edges run left to right; every edge has its route."""
    assert set(layout.boxes) == set(model.vertices())
    for one, two in itertools.combinations(layout.boxes.values(), 2):
        assert not one.overlaps(two), (one, two)
    assert {(r.source, r.target) for r in layout.routes} == model.edges
    for route in layout.routes:
        source, target = layout.boxes[route.source], layout.boxes[route.target]
        xs = [x for x, _ in route.points]
        if route.reversed:
            assert source.layer > target.layer
            assert (xs[0], xs[-1]) == (source.left, target.right)
        else:
            assert source.layer < target.layer
            assert source.x < target.x
            assert xs == sorted(xs)  # never turns back
            assert (xs[0], xs[-1]) == (source.right, target.left)
        assert route.points[0][1] == source.y and route.points[-1][1] == target.y
    for box in layout.boxes.values():
        assert box.left >= -1e-9 and box.top >= -1e-9
        assert box.right <= layout.width + 1e-9 and box.bottom <= layout.height + 1e-9


def test_publishers_topics_subscribers_left_to_right() -> None:
    model = scene()
    layout = layout_graph(model)
    check_geometry(model, layout)
    layer = {v.name: box.layer for v, box in layout.boxes.items()}
    assert layer['/talker'] < layer['/chatter'] < layer['/relay'] < layer['/relayed']
    assert layer['/relayed'] < layer['/listener']
    # every column holds one kind: nodes and topics alternate
    kinds = {box.layer: set() for box in layout.boxes.values()}
    for vertex, box in layout.boxes.items():
        kinds[box.layer].add(vertex.kind)
    assert all(len(found) == 1 for found in kinds.values())
    # the cycle a -> /x -> b -> /y -> a has exactly one edge drawn backwards
    backwards = [(r.source.name, r.target.name) for r in layout.routes if r.reversed]
    assert len(backwards) == 1 and set(backwards[0]) <= {'/a', '/x', '/b', '/y'}
    assert layout.crossings == 0
    # /chatter -> /listener skips the relay's columns: it bends through them
    (long,) = [
        r for r in layout.routes if (r.source.name, r.target.name) == ('/chatter', '/listener')
    ]
    assert len(long.points) == 2 + (layer['/listener'] - layer['/chatter'] - 1)


def test_a_node_that_publishes_and_subscribes_one_topic() -> None:
    model = GraphModel()
    model.add_publisher('/loop', '/state')
    model.add_subscriber('/loop', '/state')
    layout = layout_graph(model)
    check_geometry(model, layout)
    forward, backward = sorted(layout.routes, key=lambda r: r.reversed)
    assert not forward.reversed and backward.reversed
    assert len(backward.points) == 3  # bent, so the two arrows do not lie on each other
    assert backward.points[1][1] != forward.points[0][1]


@st.composite
def bipartite_graphs(draw: st.DrawFn) -> GraphModel:
    nodes = [f'/n{i}' for i in range(draw(st.integers(1, 9)))]
    topics = [f'/t{i}' for i in range(draw(st.integers(0, 9)))]
    model = GraphModel()
    for node in nodes:
        model.add_node(node)
    for topic in topics:
        model.add_topic(topic)
    if topics:
        pairs = st.tuples(st.sampled_from(nodes), st.sampled_from(topics), st.booleans())
        for node, topic, publishes in draw(st.lists(pairs, max_size=30)):
            if publishes:
                model.add_publisher(node, topic)
            else:
                model.add_subscriber(node, topic)
    return model


@settings(max_examples=150, deadline=None)
@given(bipartite_graphs())
def test_any_graph_lays_out_without_overlaps(model: GraphModel) -> None:
    layout = layout_graph(model)
    check_geometry(model, layout)
    assert 2 * sum(r.reversed for r in layout.routes) <= len(layout.routes)


def test_the_picture_has_one_text_and_one_shape_per_vertex_and_an_arrow_per_edge() -> None:
    model = scene()
    layout = layout_graph(model, font_measure())
    figure = draw_graph(layout, model)
    (axes,) = figure.axes
    texts = sorted(text.get_text() for text in axes.texts)
    assert texts == sorted(v.name for v in model.vertices())
    ellipses = [p for p in axes.patches if isinstance(p, Ellipse)]
    boxes = [p for p in axes.patches if isinstance(p, Rectangle)]
    arrows = [p for p in axes.patches if isinstance(p, FancyArrowPatch)]
    assert (len(ellipses), len(boxes), len(arrows)) == (
        len(model.nodes), len(model.topics), len(model.edges)
    )  # fmt: skip
    by_center = {(round(e.center[0]), round(e.center[1])): e for e in ellipses}
    for vertex, box in layout.boxes.items():
        if vertex.kind == NODE:
            shape = by_center[(round(box.x), round(box.y))]
            colors = BRIDGE_COLORS if vertex.name in model.bridges else NODE_COLORS
            assert matplotlib.colors.to_hex(shape.get_facecolor()) == colors[0]
    # each label fits inside its shape (measured with the font drawn)
    renderer = FigureCanvasAgg(figure).get_renderer()
    to_points = 72 / figure.dpi
    for text in axes.texts:
        extent = text.get_window_extent(renderer)
        box = layout.boxes[
            Vertex(TOPIC if text.get_text() in model.topics else NODE, text.get_text())
        ]
        assert extent.width * to_points <= box.width
        assert extent.height * to_points <= box.height


def test_files_png_svg_dot(tmp_path: Path) -> None:
    model = scene()
    graph(model, tmp_path / 'graph.png')
    picture = matplotlib.image.imread(tmp_path / 'graph.png')
    layout = layout_graph(model, font_measure())
    assert abs(picture.shape[1] - (layout.width + 24) * 100 / 72) <= 1  # 100 dpi, 12 pt margins
    graph(model, tmp_path / 'graph.svg')
    svg = (tmp_path / 'graph.svg').read_text()
    assert sorted(re.findall(r'>(/[\w/]+)</text>', svg)) == sorted(v.name for v in model.vertices())
    graph(model, tmp_path / 'graph.dot')
    dot = (tmp_path / 'graph.dot').read_text()
    assert '"n:/talker" -> "t:/chatter";' in dot
    assert '"t:/cmd_vel" -> "n:/zenoh_bridge_ros2dds";' in dot
    assert '"n:/lonely" [label="/lonely", shape=ellipse];' in dot
    assert dot.count(' -> ') == len(model.edges)
    assert (
        to_dot(GraphModel())
        == 'digraph ros_graph {\n  rankdir=LR;\n  node [fontname="sans-serif"];\n}\n'
    )


def test_an_empty_graph_says_so() -> None:
    figure = graph(GraphModel())
    assert figure.axes[0].get_title() == 'no nodes or topics'
    assert not figure.axes[0].texts
