"""The table of the wire schemes zros speaks: each one's name, what it is, the settings it
takes and the module of its :class:`~zros.wire.Wire`.

Light on purpose (no Zenoh, no numpy): the command line builds ``--wire`` and each scheme's
options from it without loading a scheme. A third scheme is its module and one entry here.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from zros.errors import SettingError

#: the value of a scheme's setting (``Node(bridge_namespace=...)``, ``Node(domain_id=...)``)
WireOption = str | int | None


@dataclass(frozen=True)
class WireSetting:
    """One setting a scheme takes: a keyword of ``Node(...)`` and its command-line option."""

    keyword: str  #: e.g. ``bridge_namespace``
    metavar: str
    help: str
    parse: Callable[[str], str | int] = str  #: the option's text to the value

    @property
    def flag(self) -> str:
        """The command-line option, e.g. ``--bridge-namespace``."""
        return '--' + self.keyword.replace('_', '-')


@dataclass(frozen=True)
class Scheme:
    """A wire scheme: its name (``wire=``, ``ZROS_WIRE``), a line saying what it is, its
    settings, and where its :class:`~zros.wire.Wire` class lives (``module:Class``)."""

    name: str
    help: str
    wire_class: str
    settings: tuple[WireSetting, ...] = ()

    def takes(self, keyword: str) -> bool:
        """Whether the scheme takes the setting ``keyword``."""
        return any(setting.keyword == keyword for setting in self.settings)


#: the schemes zros speaks, by name (the first is the default)
SCHEMES: dict[str, Scheme] = {
    scheme.name: scheme
    for scheme in (
        Scheme(
            'bridge',
            'zenoh-bridge-ros2dds keys (the default)',
            'zros.wire.bridge_wire:BridgeWire',
            (
                WireSetting(
                    'bridge_namespace',
                    'NS',
                    "the bridge's namespace setting (default: what the bridges report)",
                ),
            ),
        ),
        Scheme(
            'rmw_zenoh',
            'rmw_zenoh natively (no bridge)',
            'zros.wire.rmw_zenoh_wire:RmwZenohWire',
            (
                WireSetting(
                    'domain_id',
                    'ID',
                    'the ROS domain under rmw_zenoh (default: $ROS_DOMAIN_ID, else 0)',
                    int,
                ),
            ),
        ),
    )
}
DEFAULT_WIRE = next(iter(SCHEMES))


def check_wire(wire: str, source: str = 'wire') -> str:
    """``wire`` if it names a scheme zros speaks, else SettingError (a ValueError) naming
    ``source`` (where ``wire`` came from: the argument, or ``ZROS_WIRE``)."""
    if wire not in SCHEMES:
        names = ' or '.join(f'"{name}"' for name in SCHEMES)
        raise SettingError(f'{source} must be {names}, got {wire!r}')
    return wire


def chosen_wire(wire: str | None) -> str:
    """The scheme ``wire`` names, else ``ZROS_WIRE``, else the default (checked)."""
    return check_wire(
        wire or os.environ.get('ZROS_WIRE') or DEFAULT_WIRE, 'wire' if wire else 'ZROS_WIRE'
    )


def scheme_settings(wire: str, settings: Mapping[str, WireOption]) -> dict[str, WireOption]:
    """The settings given (not None) for the scheme ``wire``; TypeError for one it does not
    take (naming the scheme that does)."""
    scheme = SCHEMES[check_wire(wire)]
    given: dict[str, WireOption] = {k: v for k, v in settings.items() if v is not None}
    for keyword in given:
        if not scheme.takes(keyword):
            owners = [name for name, other in SCHEMES.items() if other.takes(keyword)]
            where = f'is for wire={owners[0]!r}' if owners else 'is no wire setting'
            raise TypeError(f'{keyword}= {where}, not wire={wire!r}')
    return given
