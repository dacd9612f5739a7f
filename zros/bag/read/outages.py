"""The recorder's link outages, kept in a bag's ``custom_data``.

``zros bag record`` notes when its session had no link to the router: messages published then
are not in the bag, and a later reader should tell that gap from a robot that went quiet. The
spans are stored under :data:`OUTAGES_KEY` in rosbag2's ``custom_data`` (``metadata.yaml``, and
the rosbag2 metadata inside the last MCAP file) as JSON: ``[[start_ns, end_ns], ...]`` in
system time.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

_log = logging.getLogger('zros.bag')

#: the ``custom_data`` key of the outages
OUTAGES_KEY = 'zros.link_outages'


@dataclass(frozen=True)
class LinkOutage:
    """A time the recorder had no link to the router, in system time (integer ns)."""

    start_ns: int
    end_ns: int

    @property
    def duration_ns(self) -> int:
        """How long it lasted, in nanoseconds."""
        return self.end_ns - self.start_ns


def outages_text(outages: Sequence[LinkOutage]) -> str:
    """The ``custom_data`` value of ``outages``."""
    return json.dumps([[o.start_ns, o.end_ns] for o in outages], separators=(',', ':'))


def read_outages(custom_data: Mapping[str, str], where: object) -> list[LinkOutage]:
    """The outages a bag's ``custom_data`` holds (none without the key); a value that does
    not parse is logged, naming ``where``, and read as none."""
    text = custom_data.get(OUTAGES_KEY)
    if text is None:
        return []
    try:
        spans = json.loads(text)
        outages = [LinkOutage(int(start), int(end)) for start, end in spans]
    except (ValueError, TypeError) as exc:
        _log.warning('%s: its %s does not read (%s): ignored', where, OUTAGES_KEY, exc)
        return []
    return sorted(outages, key=lambda o: o.start_ns)
