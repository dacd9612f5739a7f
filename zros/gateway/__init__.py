"""Gateways: WebSocket servers that show the ROS graph reached over Zenoh to browser tools.

``common`` holds what every gateway shares (name filters, following the graph, raw taps on the
watched topics only, bounded client outboxes); ``foxglove`` serves the Foxglove app
(``zros foxglove``, :func:`zros.foxglove.serve`).
"""
