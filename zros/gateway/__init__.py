"""Gateways: WebSocket servers that show the ROS graph reached over Zenoh to browser tools.

One folder per gateway: ``foxglove`` serves the Foxglove app (``zros foxglove``,
:func:`zros.foxglove.serve`), ``rosbridge`` roslibjs and roslibpy apps (``zros rosbridge``,
:func:`zros.rosbridge.serve`); ``common`` holds what they share (name filters, following the
graph, raw taps on the watched topics only, bounded client outboxes, where and for whom they
listen). The gateways do not import each other, and ``common`` imports neither.
"""
