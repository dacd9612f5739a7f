"""Plots with matplotlib: live topics (rqt_plot), recordings, and the graph picture (rqt_graph).

>>> import zros.plot                                                  # doctest: +SKIP
>>> zros.plot.live(['/imu/linear_acceleration/x'], filter=5, duration=10, png='imu.png')
>>> zros.plot.bag('run1', ['/odom/twist/twist/linear/x'], png='speed.png')
>>> zros.plot.graph(node, 'graph.svg')

Fields are addressed as rqt_plot addresses them, ``/topic/field/path``. matplotlib is imported
when a figure is made, not with this package. Without a window, figures are plain
``matplotlib.figure.Figure`` objects rendered by Agg (no display, no pyplot state).
"""

from __future__ import annotations

from zros.bag.columns.addresses import Series, resolve
from zros.plot.bag_plot import bag
from zros.plot.errors import PlotError
from zros.plot.graph_data import Box, GraphModel, Layout, Route, Vertex
from zros.plot.graph_layout import layout_graph
from zros.plot.graph_picture import draw_graph, graph, graph_model, to_dot
from zros.plot.live_plot import LivePlot, live
from zros.plot.smoothing import moving_average

__all__ = [
    'Box',
    'GraphModel',
    'Layout',
    'LivePlot',
    'PlotError',
    'Route',
    'Series',
    'Vertex',
    'bag',
    'draw_graph',
    'graph',
    'graph_model',
    'layout_graph',
    'live',
    'moving_average',
    'resolve',
    'to_dot',
]
