"""The robot in the Foxglove app, with no ROS installed: ``zros.foxglove.serve()``.

A thin door to :mod:`zros.gateway.foxglove` (the live graph, and recordings); needs the ``foxglove``
extra (``pip install 'zros-client[foxglove]'``)::

    import zros.foxglove

    with zros.foxglove.serve(connect='tcp/robot:7447') as server:
        print(server.url)   # ws://127.0.0.1:8765: open it in Foxglove
        input()
"""

from __future__ import annotations

from zros.gateway.foxglove.sdk import ServerOptions
from zros.gateway.foxglove.server import FoxgloveGateway, serve

__all__ = ['FoxgloveGateway', 'ServerOptions', 'serve']
