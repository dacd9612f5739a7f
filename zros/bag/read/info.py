"""What ``ros2 bag info`` prints about a recording, in its layout.

The layout is rosbag2's ``format_bag_meta_data`` (rosbag2_py): fields padded to 19 columns,
times in local time with nanoseconds, sizes in KiB/MiB/GiB with one decimal, topics sorted by
name, and service event topics (``<service>/_service_event`` of a ``pkg/srv/X_Event`` type)
listed as services with their event count.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from zros.bag.read.outages import LinkOutage, read_outages
from zros.bag.read.source import Connection, open_source

_NS = 1_000_000_000
_INDENT = 19
_EVENT_TOPIC = '/_service_event'
SORTS = ('name', 'type', 'count')


@dataclass(frozen=True)
class Entry:
    """A topic, or a service recorded as service events."""

    name: str
    type_name: str
    count: int
    serialization: str


@dataclass
class BagInfo:
    """The facts ``ros2 bag info`` shows; ``str()`` gives its text."""

    path: Path
    files: list[str]
    size_bytes: int
    storage_id: str
    ros_distro: str
    start_ns: int
    end_ns: int
    message_count: int
    topics: list[Entry] = field(default_factory=list)
    services: list[Entry] = field(default_factory=list)
    #: when the recorder had no link to the router (zros's ``custom_data``; not in rosbag2's text)
    outages: list[LinkOutage] = field(default_factory=list)

    @property
    def duration_ns(self) -> int:
        """Nanoseconds from the first message to the last."""
        return self.end_ns - self.start_ns

    def format(self, sort: str = 'name') -> str:
        """The text of ``ros2 bag info`` (``sort``: name, type or count)."""
        if sort not in SORTS:
            raise ValueError(f'sort by one of {", ".join(SORTS)}, not {sort!r}')
        pad = ' ' * _INDENT
        lines = ['']
        lines += _block('Files:', self.files or [''], pad)
        lines.append(f'{"Bag size:":<{_INDENT}}{format_size(self.size_bytes)}')
        lines.append(f'{"Storage id:":<{_INDENT}}{self.storage_id}')
        lines.append(f'{"ROS Distro:":<{_INDENT}}{self.ros_distro or "unknown"}')
        lines.append(f'{"Duration:":<{_INDENT}}{_seconds(self.duration_ns)}s')
        lines.append(f'{"Start:":<{_INDENT}}{format_time(self.start_ns)}')
        lines.append(f'{"End:":<{_INDENT}}{format_time(self.end_ns)}')
        events = sum(service.count for service in self.services)
        lines.append(f'{"Messages:":<{_INDENT}}{self.message_count - events}')
        if self.outages:
            down = sum(o.duration_ns for o in self.outages)
            lines += _block(
                'Link outages:',
                [
                    f'{len(self.outages)}, {down / _NS:.1f} s in all: '
                    'messages published then are missing',
                    *(
                        f'{format_time(o.start_ns)} for {o.duration_ns / _NS:.3f} s'
                        for o in self.outages
                    ),
                ],
                pad,
            )
        topics = [
            f'Topic: {t.name} | Type: {t.type_name} | Count: {t.count} | '
            f'Serialization Format: {t.serialization}'
            for t in _sorted(self.topics, sort)
        ]
        lines += _block('Topic information:', topics or [''], pad)
        lines.append(f'{"Service:":<{_INDENT}}{len(self.services)}')
        services = [
            f'Service: {s.name} | Type: {s.type_name} | Event Count: {s.count} | '
            f'Serialization Format: {s.serialization}'
            for s in _sorted(self.services, sort)
        ]
        # rosbag2 ends the text here without a line break when there is no service
        lines += _block('Service information:', services or [''], pad + '  ')
        return '\n'.join(lines)

    def __str__(self) -> str:
        return self.format()


def _block(title: str, items: list[str], pad: str) -> list[str]:
    head = f'{title} ' if len(title) + 1 > _INDENT else f'{title:<{_INDENT}}'
    return [head + items[0], *[pad + item for item in items[1:]]]


def _sorted(entries: list[Entry], sort: str) -> list[Entry]:
    key = {'name': lambda e: e.name, 'type': lambda e: e.type_name, 'count': lambda e: e.count}
    return sorted(entries, key=key[sort])


def _seconds(nanoseconds: int) -> str:
    seconds, fraction = divmod(nanoseconds, _NS)
    return f'{seconds}.{fraction:09d}'


def format_time(nanoseconds: int) -> str:
    """``Apr  2 2020 22:23:55.112411371 (1585866235.112411371)``, in local time."""
    seconds, fraction = divmod(nanoseconds, _NS)
    local = time.localtime(seconds)
    day = f'{local.tm_mday:>2}'
    text = time.strftime(f'%b {day} %Y %H:%M:%S', local)
    return f'{text}.{fraction:09d} ({_seconds(nanoseconds)})'


def format_size(size: int) -> str:
    """Bytes as rosbag2 prints them: ``812 B``, ``14.2 KiB``, ``1.5 GiB``."""
    value = float(size)
    units = ('B', 'KiB', 'MiB', 'GiB', 'TiB')
    index = 0
    while value >= 1024 and index < len(units) - 1:
        value /= 1024
        index += 1
    return f'{value:.0f} {units[index]}' if index == 0 else f'{value:.1f} {units[index]}'


def _is_service_event(connection: Connection) -> bool:
    parts = connection.type_name.split('/')
    return (
        connection.topic.endswith(_EVENT_TOPIC)
        and len(connection.topic) > len(_EVENT_TOPIC)
        and len(parts) == 3
        and parts[1] == 'srv'
        and parts[2].endswith('_Event')
    )


def info(path: str | Path) -> BagInfo:
    """Read what ``ros2 bag info`` shows about a recording (``str()`` of the result prints it)."""
    with open_source(path) as source:
        location = source.path
        if location.is_dir():
            size = sum(f.stat().st_size for f in location.iterdir() if f.is_file())
            files = [f.name for f in source.files if f.name != 'metadata.yaml']
        else:
            size = location.stat().st_size
            files = [location.name]
        result = BagInfo(
            location,
            files,
            size,
            source.storage_id,
            source.ros_distro or '',
            source.start_ns,
            source.end_ns,
            source.message_count,
            outages=read_outages(source.custom_data, location),
        )
        grouped: dict[tuple[str, str], list[Connection]] = {}
        for connection in source.connections:
            grouped.setdefault((connection.topic, connection.type_name), []).append(connection)
        for (topic, type_name), group in grouped.items():
            count = sum(c.count for c in group)
            # a ROS 1 bag's messages are read as CDR, but recorded (and shown) as ros1
            serialization = 'ros1' if source.storage_id == 'rosbag1' else group[0].serialization
            if _is_service_event(group[0]):
                service = topic[: -len(_EVENT_TOPIC)]
                entry = Entry(service, type_name[: -len('_Event')], count, serialization)
                result.services.append(entry)
            else:
                result.topics.append(Entry(topic, type_name, count, serialization))
    return result
