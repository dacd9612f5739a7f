"""A stand-in for zenoh-bridge-ros2dds 1.x: an rclpy node on one side, a Zenoh router on the other.

Run it with ``python -m tests.interop.bridge_standin --listen <endpoint> [--namespace /bot1]``.
``protocol`` holds the key/token/QoS/attachment formats (pure, unit tested), ``topics`` and
``services`` the routes, ``runtime`` the bridge that discovers ROS entities and reacts to tokens.
Nothing here imports zros, so a mistake in zros's key code cannot be mirrored.
"""
