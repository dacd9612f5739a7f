"""``zros graph`` (rqt_graph): the ROS graph drawn in a window when matplotlib has a display,
else (or with ``-o``) into a file through Agg. matplotlib is imported only when it runs.
"""

from __future__ import annotations

import argparse

from zros.cli.shared import DISCOVERY, add_connection_options, counted, open_node, out

DEFAULT_GRAPH = 'graph.png'  #: where the picture goes when there is no display and no -o


def graph(args: argparse.Namespace) -> int:
    from zros.plot.figure import can_show
    from zros.plot.graph_picture import graph as draw
    from zros.plot.graph_picture import graph_model

    with open_node(args) as node:
        node.graph.refresh(DISCOVERY)
        model = graph_model(node, hide_hidden=args.hide_hidden, hide_debug=args.hide_debug)
    output = args.output
    show = output is None and can_show()
    if output is None and not show:
        output = DEFAULT_GRAPH
    draw(model, output, show=show)
    summary = ', '.join(
        counted(len(items), noun)
        for items, noun in ((model.nodes, 'node'), (model.topics, 'topic'), (model.edges, 'edge'))
    )
    out(summary + (f' -> {output}' if output else ''))
    return 0


def add_parser(
    commands: argparse._SubParsersAction[argparse.ArgumentParser], help_line: str
) -> None:
    text = 'draw the ROS graph like rqt_graph: nodes, topics, publisher -> topic -> subscriber'
    parser = commands.add_parser('graph', help=help_line, description=text)
    parser.set_defaults(run=graph)
    parser.add_argument(
        '-o',
        '--output',
        metavar='FILE',
        help='write the picture: .png, .svg, .pdf, or .dot (Graphviz text); '
        'default: a window, or graph.png without a display',
    )
    parser.add_argument(
        '--hide-hidden',
        action=argparse.BooleanOptionalAction,
        default=True,
        help='leave out hidden names (a part starting with _)',
    )
    parser.add_argument(
        '--hide-debug',
        action=argparse.BooleanOptionalAction,
        default=True,
        help='leave out /rosout and /parameter_events',
    )
    add_connection_options(parser)
