"""``--qos-profile``, ``--qos-depth``, ``--qos-history``, ``--qos-reliability`` and
``--qos-durability`` of ``topic echo`` and ``topic pub``, as ``ros2 topic`` spells them."""

from __future__ import annotations

import argparse
from collections.abc import Iterable

from zros.cli.arg_types import at_least_one
from zros.cli.shared import UsageError
from zros.qos import (
    DEFAULT,
    LATCHED,
    PARAMETER_EVENTS,
    SENSOR_DATA,
    Durability,
    History,
    QoS,
    QoSChanges,
    Reliability,
)

#: ros2's preset profiles (rclpy's QoSPresetProfiles short keys) as zros QoS
PROFILES = {
    'system_default': DEFAULT,
    'sensor_data': SENSOR_DATA,
    'services_default': DEFAULT,
    'parameters': PARAMETER_EVENTS,
    'parameter_events': PARAMETER_EVENTS,
    'action_status_default': LATCHED,
    'best_available': DEFAULT,
}
#: 'best_available' (and an echo given no policy): the publishers' choice, as ros2
MATCH = 'best_available'
_RELIABILITY = {'system_default': Reliability.RELIABLE, 'reliable': Reliability.RELIABLE,
                'best_effort': Reliability.BEST_EFFORT}  # fmt: skip
_DURABILITY = {'system_default': Durability.VOLATILE, 'volatile': Durability.VOLATILE,
               'transient_local': Durability.TRANSIENT_LOCAL}  # fmt: skip
_HISTORY = {'system_default': History.KEEP_LAST, 'keep_last': History.KEEP_LAST,
            'keep_all': History.KEEP_ALL}  # fmt: skip


def add_qos_options(parser: argparse.ArgumentParser, role: str, default: str) -> None:
    """The QoS options of a command that ``role``s (subscribe, publish); ``default``: what it
    uses without them, in words."""
    group = parser.add_argument_group('quality of service (as ros2 topic)')
    group.add_argument(
        '--qos-profile', choices=tuple(PROFILES),
        help=f'the preset profile to {role} with (default: {default})',
    )  # fmt: skip
    group.add_argument(
        '--qos-depth', type=at_least_one, metavar='N',
        help="queue size (overrides the profile's depth)",
    )  # fmt: skip
    for name, choices in (
        ('history', _HISTORY),
        ('reliability', _RELIABILITY),
        ('durability', _DURABILITY),
    ):
        group.add_argument(
            f'--qos-{name}', choices=(*choices, MATCH) if name != 'history' else tuple(choices),
            help=f"overrides the profile's {name}",
        )  # fmt: skip


def chosen_qos(args: argparse.Namespace, base: QoS, offered: Iterable[QoS] | None) -> QoS:
    """The QoS the options ask for: ``base`` unless ``--qos-profile``, with each policy given
    overriding the profile's. ``offered``: a subscriber's, the QoS of the topic's publishers;
    the reliability and durability not given (or ``best_available``) then match them, as
    ros2's echo does (reliable, transient local only when every publisher is)."""
    qos = PROFILES[args.qos_profile] if args.qos_profile else base
    changes: QoSChanges = {}
    if args.qos_depth is not None:
        changes['depth'] = args.qos_depth
    if args.qos_history is not None:
        changes['history'] = _HISTORY[args.qos_history]
    offers = None if offered is None else list(offered)
    reliability = _policy(args.qos_reliability, _RELIABILITY, offers, 'reliable')
    if reliability is not None:
        changes['reliability'] = Reliability(reliability)
    durability = _policy(args.qos_durability, _DURABILITY, offers, 'transient_local')
    if durability is not None:
        changes['durability'] = Durability(durability)
    try:
        return qos.with_(**changes)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _policy(
    given: str | None,
    policies: dict[str, Reliability] | dict[str, Durability],
    offers: list[QoS] | None,
    attribute: str,
) -> int | None:
    """The level of a policy: the one ``given``; else, with ``offers``, the higher level when
    every offer has ``attribute``, the lower when not; a publisher's ``best_available``: the
    higher; None: the profile's."""
    if given is not None and given in policies:
        return policies[given]
    levels = sorted(set(policies.values()))
    if offers:
        return levels[-1] if all(getattr(q, attribute) for q in offers) else levels[0]
    return levels[-1] if given == MATCH else None
