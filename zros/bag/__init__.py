"""Recordings: read ROS 2 bags (folders, .mcap, .db3) and ROS 1 bags; record and play MCAP bags.

>>> from zros.bag import Bag                                      # doctest: +SKIP
>>> with Bag('my_bag') as bag:
...     odom = bag.columns('/odom', ['pose.pose.position.x', 'pose.pose.position.y'])
"""

from __future__ import annotations

from zros.bag.bag_writer import BagTopic, BagWriteError, BagWriter
from zros.bag.errors import BagError
from zros.bag.info import BagInfo, info
from zros.bag.play_topics import PlayerError
from zros.bag.player import Player
from zros.bag.reader import Bag, TopicInfo
from zros.bag.recorder import Recorder, RecorderError
from zros.bag.reindexer import FileReport, ReindexReport, reindex
from zros.bag.rosr import BagRead, bag_read
from zros.bag.source import Connection, RawMessage, Source, open_source
from zros.bag.types import UndecodedMessage

__all__ = [
    'Bag',
    'BagError',
    'BagInfo',
    'BagRead',
    'BagTopic',
    'BagWriteError',
    'BagWriter',
    'Connection',
    'FileReport',
    'Player',
    'PlayerError',
    'RawMessage',
    'Recorder',
    'RecorderError',
    'ReindexReport',
    'Source',
    'TopicInfo',
    'UndecodedMessage',
    'bag_read',
    'info',
    'open_source',
    'reindex',
]
