"""Recordings: read ROS 2 bags (folders, .mcap, .db3) and ROS 1 bags."""

from __future__ import annotations

from zros.bag.errors import BagError
from zros.bag.source import Connection, RawMessage, Source, open_source

__all__ = ['BagError', 'Connection', 'RawMessage', 'Source', 'open_source']
