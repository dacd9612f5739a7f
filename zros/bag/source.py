"""Raw messages of a recording, in time order, with nothing decoded.

:func:`open_source` opens a ROS 2 bag folder (``metadata.yaml`` with ``.db3`` or ``.mcap``
files, split or not), a bare ``.mcap`` or ``.db3`` file, or a ROS 1 ``.bag`` file. The storage
formats are read by ``rosbags``; this module gives them one shape: :class:`Connection` per
topic and type, :class:`RawMessage` per message, CDR bytes throughout.

ROS 1 messages are converted to CDR as ``rosbags-convert`` converts them: ``std_msgs/Header``
loses its ``seq``, so a ROS 1 message has the layout of its ROS 2 namesake. Their connections
carry ROS 2 ``.msg`` text generated from the ROS 1 connection headers.
"""

from __future__ import annotations

from pathlib import Path

from zros.bag.errors import BagError
from zros.bag.rosbag1_source import Rosbag1Source
from zros.bag.rosbag2_source import Rosbag2Source
from zros.bag.source_base import (
    Block,
    Connection,
    RawMessage,
    Source,
    describe_error,
    normalise_type_name,
)


def open_source(path: str | Path) -> Source:
    """Open a recording for raw reading; raises :class:`BagError` naming the file and cause."""
    location = Path(path).expanduser()
    if not location.exists():
        raise BagError(location, 'no such file or folder')
    source: Rosbag1Source | Rosbag2Source
    if location.is_dir():
        source = Rosbag2Source(location)
    elif location.suffix == '.bag':
        source = Rosbag1Source(location)
    elif location.suffix in ('.mcap', '.db3'):
        source = Rosbag2Source(location)
    elif location.name == 'metadata.yaml':
        return open_source(location.parent)
    else:
        raise BagError(
            location,
            'not a recording zros reads (expected a bag folder, .mcap, .db3 or ROS 1 .bag)',
        )
    try:
        source.open()
    except BagError:
        source.close()
        raise
    except Exception as exc:  # the storage libraries raise what they like on a damaged file
        source.close()
        raise BagError(location, f'cannot open the recording: {describe_error(exc)}') from exc
    return source


__all__ = ['Block', 'Connection', 'RawMessage', 'Source', 'normalise_type_name', 'open_source']
