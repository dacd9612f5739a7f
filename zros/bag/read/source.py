"""Raw messages of a recording, in time order, with nothing decoded.

:func:`open_source` opens a ROS 2 bag folder (``metadata.yaml`` with ``.db3`` or ``.mcap``
files, split or not), a bare ``.mcap`` or ``.db3`` file, or a ROS 1 ``.bag`` file. The storage
formats are read by ``rosbags``; this module gives them one shape: :class:`Connection` per
topic and type, :class:`RawMessage` per message, CDR bytes throughout.

ROS 1 messages are converted to CDR as ``rosbags-convert`` converts them: ``std_msgs/Header``
loses its ``seq``, so a ROS 1 message has the layout of its ROS 2 namesake. Their connections
carry ROS 2 ``.msg`` text generated from the ROS 1 connection headers.

:data:`FORMATS` is the extension point: a new storage format is one module with a
:class:`Source` subclass and one entry there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from zros.bag.errors import BagError
from zros.bag.read.rosbag1 import Rosbag1Source
from zros.bag.read.rosbag2 import Rosbag2Source
from zros.bag.read.source_base import (
    Block,
    Connection,
    RawMessage,
    Source,
    describe_error,
    normalise_type_name,
)


@dataclass(frozen=True)
class Format:
    """A storage format zros reads: what its paths look like, and the :class:`Source` that
    reads one (constructed with the path, then opened)."""

    detect: Callable[[Path], bool]
    reader: Callable[[Path], Source]
    #: how an error message names its paths
    described: str


#: format name -> :class:`Format`; the first whose ``detect`` accepts a path reads it
FORMATS: dict[str, Format] = {
    'rosbag2': Format(
        lambda path: path.is_dir() or path.suffix in ('.mcap', '.db3'),
        Rosbag2Source,
        'a bag folder, .mcap, .db3',
    ),
    'rosbag1': Format(lambda path: path.suffix == '.bag', Rosbag1Source, 'ROS 1 .bag'),
}


def open_source(path: str | Path, strict: bool = False) -> Source:
    """Open a recording for raw reading; raises :class:`BagError` naming the file and cause.

    Damaged parts are skipped and reported in ``source.damage`` (see
    :mod:`zros.bag.read.damage`); ``strict`` raises :class:`BagError` on them instead.
    """
    location = Path(path).expanduser()
    if not location.exists():
        raise BagError(location, 'no such file or folder')
    if location.name == 'metadata.yaml' and not location.is_dir():
        location = location.parent
    found = next((f for f in FORMATS.values() if f.detect(location)), None)
    if found is None:
        expected = ' or '.join(f.described for f in FORMATS.values())
        raise BagError(location, f'not a recording zros reads (expected {expected})')
    source = found.reader(location)
    source.damage.strict = strict
    try:
        source.open()
    except BagError:
        source.close()
        raise
    except Exception as exc:  # the storage libraries raise what they like on a damaged file
        source.close()
        raise BagError(location, f'cannot open the recording: {describe_error(exc)}') from exc
    return source


__all__ = [
    'FORMATS',
    'Block',
    'Connection',
    'Format',
    'RawMessage',
    'Source',
    'normalise_type_name',
    'open_source',
]
