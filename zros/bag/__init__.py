"""Recordings: read ROS 2 bags (folders, .mcap, .db3) and ROS 1 bags; record and play MCAP bags.

>>> from zros.bag import Bag                                      # doctest: +SKIP
>>> with Bag('my_bag') as bag:
...     odom = bag.columns('/odom', ['pose.pose.position.x', 'pose.pose.position.y'])

The names load on first use: reading a bag never imports the recorder or the player, so it
never loads Zenoh.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from zros.bag.errors import AddressError, BagError, BagWriteError, PlayerError, RecorderError

#: public name -> module defining it, imported on first access
_LAZY = {
    'Bag': 'zros.bag.reader',
    'TopicInfo': 'zros.bag.reader',
    'BagRead': 'zros.bag.rosr',
    'bag_read': 'zros.bag.rosr',
    'BagInfo': 'zros.bag.read.info',
    'info': 'zros.bag.read.info',
    'Connection': 'zros.bag.read.source',
    'RawMessage': 'zros.bag.read.source',
    'Skipped': 'zros.bag.read.damage',
    'LinkOutage': 'zros.bag.read.outages',
    'Source': 'zros.bag.read.source',
    'open_source': 'zros.bag.read.source',
    'UndecodedMessage': 'zros.bag.read.types',
    'BagTopic': 'zros.bag.write.bag_writer',
    'BagWriter': 'zros.bag.write.bag_writer',
    'Recorder': 'zros.bag.write.recorder',
    'FileReport': 'zros.bag.write.reindexer',
    'ReindexReport': 'zros.bag.write.reindexer',
    'reindex': 'zros.bag.write.reindexer',
    'Player': 'zros.bag.play.player',
}

if TYPE_CHECKING:
    from zros.bag.play.player import Player
    from zros.bag.read.damage import Skipped
    from zros.bag.read.info import BagInfo, info
    from zros.bag.read.outages import LinkOutage
    from zros.bag.read.source import Connection, RawMessage, Source, open_source
    from zros.bag.read.types import UndecodedMessage
    from zros.bag.reader import Bag, TopicInfo
    from zros.bag.rosr import BagRead, bag_read
    from zros.bag.write.bag_writer import BagTopic, BagWriter
    from zros.bag.write.recorder import Recorder
    from zros.bag.write.reindexer import FileReport, ReindexReport, reindex


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # the next access skips this function
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_LAZY])


__all__ = [
    'AddressError',
    'Bag',
    'BagError',
    'BagInfo',
    'BagRead',
    'BagTopic',
    'BagWriteError',
    'BagWriter',
    'Connection',
    'FileReport',
    'LinkOutage',
    'Player',
    'PlayerError',
    'RawMessage',
    'Recorder',
    'RecorderError',
    'ReindexReport',
    'Skipped',
    'Source',
    'TopicInfo',
    'UndecodedMessage',
    'bag_read',
    'info',
    'open_source',
    'reindex',
]
