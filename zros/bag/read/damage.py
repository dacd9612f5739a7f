"""What a damaged recording lost: a :class:`Skipped` record per damaged unit and topic.

A chunk (MCAP, ROS 1), a row (db3), a record or a message that does not decompress, parse or
decode is skipped and everything else is read. Each damaged unit is logged once (logger
``zros.bag``) naming the file, the byte offset or row, the topics and how many messages each
lost; :class:`Damage` keeps the records (``Bag.skipped``). In strict mode it raises
:class:`~zros.bag.errors.BagError` with the same text instead.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

from zros.bag.errors import BagError

_log = logging.getLogger('zros.bag')
#: damaged messages of one topic logged one by one; later ones are counted, logged at debug
_LOGGED_PER_TOPIC = 10


@dataclass(frozen=True)
class Skipped:
    """Messages of one topic a damaged unit of a recording lost.

    ``offset`` is the unit's byte offset in ``file`` (None where the storage has none: a db3
    row); ``row`` is the db3 row id, the first of a run of rows lost (else None); ``lost`` is how
    many messages of ``topic`` the unit held (-1 when the damage hides it).
    """

    file: Path
    offset: int | None
    row: int | None
    topic: str
    lost: int
    reason: str

    @property
    def where(self) -> str:
        """``byte N``, ``row N`` or ``''``."""
        if self.row is not None:
            return f'row {self.row}'
        return '' if self.offset is None else f'byte {self.offset}'

    def __str__(self) -> str:
        return f'{self.file}: {_reason([self])}'


def _reason(losses: list[Skipped]) -> str:
    first = losses[0]
    lost = ', '.join(
        f'{"an unknown number of" if s.lost < 0 else s.lost} message{"" if s.lost == 1 else "s"} '
        f'of {s.topic or "unknown topics"}'
        for s in losses
    )
    where = f' at {first.where}' if first.where else ''
    return f'skipped the damaged data{where} ({first.reason}): lost {lost}'


class Damage:
    """The losses of one open recording; ``strict`` raises on the first instead."""

    def __init__(self, strict: bool = False) -> None:
        self.strict = strict
        self.skipped: list[Skipped] = []
        self._seen: set[Skipped] = set()
        self._logged: dict[str, int] = {}

    def report(self, losses: list[Skipped]) -> None:
        """One damaged unit's losses (a record per topic): logged once, kept, or raised."""
        if not losses:
            return
        if self.strict:
            raise BagError(losses[0].file, _reason(losses))
        fresh = [loss for loss in losses if loss not in self._seen]
        if not fresh:
            return  # read again: reported already
        self._seen.update(fresh)
        self.skipped += fresh
        text = f'{fresh[0].file}: {_reason(fresh)}'
        topic = fresh[0].topic
        logged = self._logged[topic] = self._logged.get(topic, 0) + 1
        if logged < _LOGGED_PER_TOPIC:
            _log.warning('%s', text)
        elif logged == _LOGGED_PER_TOPIC:
            _log.warning(
                '%s; further damage on %s is counted in Bag.skipped, not logged',
                text,
                topic or 'unknown topics',
            )
        else:
            _log.debug('%s', text)
