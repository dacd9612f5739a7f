"""Recordings: read ROS 2 bags (folders, .mcap, .db3) and ROS 1 bags.

>>> from zros.bag import Bag                                      # doctest: +SKIP
>>> with Bag('my_bag') as bag:
...     odom = bag.columns('/odom', ['pose.pose.position.x', 'pose.pose.position.y'])
"""

from __future__ import annotations

from zros.bag.errors import BagError
from zros.bag.reader import Bag, TopicInfo
from zros.bag.rosr import BagRead, bag_read
from zros.bag.source import Connection, RawMessage, Source, open_source

__all__ = [
    'Bag',
    'BagError',
    'BagRead',
    'Connection',
    'RawMessage',
    'Source',
    'TopicInfo',
    'bag_read',
    'open_source',
]
