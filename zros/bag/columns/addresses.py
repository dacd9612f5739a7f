"""Field addresses (``/imu/linear_acceleration/x``): which topic, which field, which element.

An address is a topic name followed by a field path, both with slashes, as rqt_plot takes
them. Where the topic ends is not written down: :func:`resolve` tries the known topics that are
prefixes of the address, longest first, and keeps the first whose message type has the rest as
a field. A field that is a message stands for its numeric fields (``/imu/linear_acceleration``
is ``x``, ``y`` and ``z``; a whole topic leaves out its ``header``); an element of an array is
``name[i]`` or ``name/i`` (``/joint_states/position[0]``). ``zros plot`` and ``Bag.columns``
take the same addresses.
"""

from __future__ import annotations

import keyword
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, SupportsFloat

import numpy as np

if TYPE_CHECKING:
    import numpy.typing as npt

    from zros.cdr import Message

from zros.bag.errors import AddressError

#: ROS primitive types that plot as numbers
NUMERIC = frozenset({
    'bool', 'byte', 'char', 'octet', 'int8', 'uint8', 'int16', 'uint16', 'int32', 'uint32',
    'int64', 'uint64', 'float32', 'float64', 'float', 'double',
})  # fmt: skip
_TYPE = re.compile(r'^(?P<base>[^\[<]+)(?:<=\d+)?(?P<array>\[(?P<bound><=)?(?P<size>\d*)\])?$')
_INDEXED = re.compile(r'^(?P<name>.*?)\[(?P<index>\d+)\]$')


@dataclass(frozen=True)
class Series:
    """One plotted quantity: a numeric field (or one element of an array) of a topic."""

    label: str  #: the address, as the legend shows it: ``/imu/linear_acceleration/x``
    topic: str  #: ``/imu``
    type_name: str  #: ``sensor_msgs/msg/Imu``
    field: str  #: the ROS field path, dotted: ``linear_acceleration.x``
    index: int | None = None  #: the element of an array field, else None

    @property
    def attributes(self) -> tuple[str, ...]:
        """The Python attribute names along :attr:`field` (keywords get a trailing ``_``)."""
        return tuple(
            part + '_' if keyword.iskeyword(part) else part for part in self.field.split('.')
        )

    def value(self, message: Message) -> float:
        """The value of this field in ``message`` as a float (NaN for a missing element)."""
        owner = message  # the message holding the field: nested messages are Messages
        *path, last = self.attributes
        for name in path:
            owner = getattr(owner, name)
        if self.index is None:
            number: SupportsFloat = getattr(owner, last)
            return float(number)
        numbers: Sequence[SupportsFloat] = getattr(owner, last)  # a list or a numpy array
        if self.index >= len(numbers):
            return float('nan')
        return float(numbers[self.index])

    def column(
        self, columns: Mapping[str, npt.NDArray[np.generic[object]]]
    ) -> npt.NDArray[np.float64]:
        """This field's values as float64, from the columns ``Bag.columns`` returns."""
        column = columns[self.field]
        if self.index is None:
            return np.asarray(column, dtype=np.float64)
        index = self.index
        if column.dtype != object:
            if index >= column.shape[1]:
                raise AddressError(self._too_short({column.shape[1]}))
            return np.asarray(column[:, index], dtype=np.float64)
        lengths = {len(row) for row in column}
        if lengths and index >= max(lengths):
            raise AddressError(self._too_short(lengths))
        return np.array([row[index] if index < len(row) else np.nan for row in column], np.float64)

    def _too_short(self, lengths: set[int]) -> str:
        shown = ', '.join(str(n) for n in sorted(lengths)[:5]) + (', …' if len(lengths) > 5 else '')
        return (
            f'{self.label}: {self.field} has {shown} element{"" if lengths == {1} else "s"} in '
            f'this recording, no element {self.index}'
        )


def _parse_type(text: str) -> tuple[str, int | None]:
    """``float64[9]`` -> (``float64``, 9); a sequence has size -1, a single value None."""
    match = _TYPE.match(text)
    if match is None:
        return text, None
    if not match['array']:
        return match['base'], None
    size = match['size']
    return match['base'], (int(size) if size and not match['bound'] else -1)


def _fields(instance: Message) -> dict[str, str]:
    found: dict[str, str] = instance.get_fields_and_field_types()
    return found


def _attribute(name: str) -> str:
    return name + '_' if keyword.iskeyword(name) else name


def _leaves(instance: Message, prefix: str, skip_header: bool) -> list[str]:
    """The numeric scalar fields under a message instance, as dotted ROS paths."""
    found = []
    for name, type_text in _fields(instance).items():
        if skip_header and name == 'header':
            continue
        base, size = _parse_type(type_text)
        path = f'{prefix}{name}'
        if size is None and base in NUMERIC:
            found.append(path)
        elif size is None and '/' in base:
            found += _leaves(getattr(instance, _attribute(name)), path + '.', False)
    return found


def _split_parts(field: str) -> list[str]:
    """``a/b[2]/c`` -> ``['a', 'b', '2', 'c']`` (indices become parts of their own)."""
    parts: list[str] = []
    for part in field.replace('.', '/').split('/'):
        if not part:
            continue
        match = _INDEXED.match(part)
        if match is not None and match['name']:
            parts += [match['name'], match['index']]
        else:
            parts.append(part)
    return parts


def field_series(
    address: str, topic: str, type_name: str, field: str, cls: Callable[[], Message]
) -> list[Series]:
    """The series ``field`` names in messages of ``cls`` (``/``- or ``.``-separated).

    Raises :class:`AddressError` saying why when the field is absent or not numeric.
    """
    instance = cls()
    parts = _split_parts(field)
    path: list[str] = []
    for position, part in enumerate(parts):
        types = _fields(instance)
        if part not in types:
            where = '.'.join(path) or type_name
            known = ', '.join(types) or 'no fields'
            raise AddressError(f'{address}: {where} has no field {part!r} (it has: {known})')
        base, size = _parse_type(types[part])
        path.append(part)
        rest = parts[position + 1 :]
        dotted = '.'.join(path)
        if size is not None:
            if base not in NUMERIC:
                raise AddressError(
                    f'{address}: {dotted} is an array of {base}; only numeric fields and '
                    'elements of numeric arrays plot'
                )
            if not rest or not rest[0].isdigit():
                example = f'{topic}/{"/".join(path)}[0]'
                raise AddressError(
                    f'{address}: {dotted} is an array: plot an element, e.g. {example}'
                )
            index = int(rest[0])
            if size >= 0 and index >= size:
                raise AddressError(f'{address}: {dotted} has {size} elements, not {index + 1}')
            if rest[1:]:
                raise AddressError(f'{address}: {dotted}[{index}] is a number, it has no fields')
            return [Series(address, topic, type_name, dotted, index)]
        if base in NUMERIC:
            if rest:
                raise AddressError(f'{address}: {dotted} is a number, it has no field {rest[0]!r}')
            return [Series(address, topic, type_name, dotted)]
        if '/' not in base:
            raise AddressError(f'{address}: {dotted} is a {base}, not a number')
        instance = getattr(instance, _attribute(part))
    leaves = _leaves(instance, '.'.join(path) + '.' if path else '', skip_header=not path)
    if not leaves:
        raise AddressError(f'{address}: {".".join(path) or type_name} has no numeric fields')
    return [Series(f'{topic}/{leaf.replace(".", "/")}', topic, type_name, leaf) for leaf in leaves]


def split_address(address: str, topics: Sequence[str]) -> list[tuple[str, str]]:
    """The ways to read ``address`` as (known topic, field path), longest topic first."""
    if not address.startswith('/'):
        raise AddressError(
            f'{address}: an address starts with the topic, e.g. /imu/angular_velocity/z'
        )
    address = address.rstrip('/')
    known = set(topics)
    found = []
    end = len(address)
    while end > 0:
        prefix = address[:end]
        if prefix in known:
            found.append((prefix, address[end + 1 :]))
        end = address.rfind('/', 0, end)
    return found


def resolve(
    address: str,
    topic_types: Mapping[str, str],
    message_class: Callable[[str, str], Callable[[], Message]],
) -> list[Series]:
    """The series an address names, given the topics known (name -> type).

    ``message_class(topic, type_name)`` gives the class of a topic's messages. Tries every known
    topic that prefixes the address, longest first; the first whose type has the rest as a
    numeric field wins. Raises :class:`AddressError` naming the problem otherwise.
    """
    candidates = split_address(address, list(topic_types))
    if not candidates:
        raise AddressError(f'{address}: no known topic starts this address')
    first_error: AddressError | None = None
    for topic, field in candidates:
        type_name = topic_types[topic]
        try:
            return field_series(address, topic, type_name, field, message_class(topic, type_name))
        except AddressError as exc:
            first_error = first_error or exc
    assert first_error is not None
    raise first_error


def topic_series(
    address: str,
    topic_types: Mapping[str, str],
    message_class: Callable[[str, str], Callable[[], Message]],
    where: str,
) -> list[Series]:
    """:func:`resolve`, with an error naming the topics of ``where`` (a recording) when no
    topic starts the address."""
    if not split_address(address, list(topic_types)):
        raise AddressError(
            f'{address}: no topic of {where} starts this address; it has: '
            + (', '.join(topic_types) or 'no topics')
        )
    return resolve(address, topic_types, message_class)


def is_address(text: str) -> bool:
    """Whether a field is written as an address (slashes, ``[i]``) rather than dotted."""
    return '/' in text or '[' in text


def column_series(
    topic: str,
    fields: Iterable[str] | None,
    topic_types: Mapping[str, str],
    message_class: Callable[[str, str], Callable[[], Message]],
    where: str,
) -> tuple[str, list[str] | None, list[Series]]:
    """What ``Bag.columns(topic, fields)`` reads, either written as an address: the topic, the
    dotted fields to extract (None: all) and the series the addresses name.

    ``topic`` may be a whole address (``/odom/pose/pose/position/x``; ``fields`` then None), a
    field ``pose/pose/position/x`` or ``position[0]`` / ``position/0``; dotted fields pass as
    they are. Raises :class:`AddressError` as ``zros plot`` does.
    """
    series: list[Series] = []
    if topic not in topic_types and split_address(topic, list(topic_types)):
        if fields is not None:
            raise AddressError(
                f'{topic}: an address names its fields; give fields only with a topic name'
            )
        series = topic_series(topic, topic_types, message_class, where)
        topic = series[0].topic
    elif fields is not None and topic in topic_types:
        fields = list(fields)
        cls = message_class(topic, topic_types[topic])
        for field in fields:
            if is_address(field):
                address = f'{topic}/{field.lstrip("/")}'
                series += field_series(address, topic, topic_types[topic], field, cls)
        fields = [f for f in fields if not is_address(f)]
    if not series:
        return topic, None if fields is None else list(fields), []
    return topic, list(dict.fromkeys([*(fields or []), *(s.field for s in series)])), series


def series_columns(
    columns: dict[str, npt.NDArray[np.generic[object]]], series: list[Series], plain: list[str]
) -> dict[str, npt.NDArray[np.generic[object]]]:
    """The columns read for :func:`column_series`, an element as ``name[i]`` (float64, NaN
    where a message has fewer) in place of its whole array unless ``plain`` asked for it."""
    found = dict(columns)
    elements = [one for one in series if one.index is not None]
    for one in elements:
        found[f'{one.field}[{one.index}]'] = one.column(columns)
    for one in elements:
        if one.field not in plain:
            found.pop(one.field, None)
    return found
