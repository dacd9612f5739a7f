"""Web apps built on roslibjs and roslibpy, with no ROS installed: ``zros.rosbridge.serve()``.

A thin door to :mod:`zros.gateway.rosbridge`; needs the ``rosbridge`` extra
(``pip install 'zros-client[rosbridge]'``)::

    import zros.rosbridge

    with zros.rosbridge.serve(connect='tcp/robot:7447') as server:
        print(server.url)   # ws://127.0.0.1:9090: new ROSLIB.Ros({url: ...})
        input()
"""

from __future__ import annotations

from zros.gateway.common.listen import Listen
from zros.gateway.rosbridge.server import RosbridgeGateway, serve

__all__ = ['Listen', 'RosbridgeGateway', 'serve']
