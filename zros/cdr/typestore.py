"""Message definitions from the typestores of rosbags (one per ROS distro).

The typestores drop default values and keep the placeholder member of empty messages; the
conversion restores the few defaults that are not zero and hides the placeholder.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from zros.cdr.model import Constant, Field, FieldType, Kind, MessageDef

if TYPE_CHECKING:
    from rosbags.interfaces.typing import BaseDesc, Constdefs, Fielddefs, NameDesc

#: rosbags and rclpy keep this dummy member in empty messages; zros hides it (the byte is still
#: on the wire).
PLACEHOLDER_FIELD = 'structure_needs_at_least_one_member'

#: Default values the rosbags typestores drop: (type, field) -> (value, constant that must exist).
#: Only defaults that differ from zero matter; the rest equal the implicit default.
_TYPESTORE_DEFAULTS: dict[tuple[str, str], tuple[float | int, str | None]] = {
    ('geometry_msgs/msg/Quaternion', 'w'): (1.0, None),
    ('sensor_msgs/msg/NavSatStatus', 'status'): (-2, 'STATUS_UNKNOWN'),  # Jazzy and later
}


#: the origin of definitions from the rosbags typestore
TYPESTORE_ORIGIN = 'rosbags typestore'


def from_rosbags(name: str, fielddefs: tuple[Constdefs, Fielddefs]) -> MessageDef:
    """Convert one rosbags typestore entry to a MessageDef."""
    from rosbags.interfaces import Nodetype  # rosbags loads on first use: start-up stays fast  # noqa: PLC0415 (lazy: rosbags, import time)

    def base_of(desc: BaseDesc | NameDesc) -> tuple[str, int]:
        if desc[0] == Nodetype.NAME:
            return desc[1], 0
        return desc[1][0], desc[1][1]

    constants = tuple(
        Constant(cname, FieldType(ctype), value) for cname, ctype, value in fielddefs[0]
    )
    fields = []
    for fname, desc in fielddefs[1]:
        if desc[0] in (Nodetype.BASE, Nodetype.NAME):
            base, bound = base_of(desc)
            ftype = FieldType(base, Kind.SCALAR, 0, bound)
        else:
            sub, length = desc[1]
            base, bound = base_of(sub)
            if desc[0] == Nodetype.ARRAY:
                kind = Kind.ARRAY
            else:
                kind = Kind.BOUNDED if length else Kind.SEQUENCE
            ftype = FieldType(base, kind, length, bound)
        default = None
        patch = _TYPESTORE_DEFAULTS.get((name, fname))
        if patch is not None and (patch[1] is None or any(c.name == patch[1] for c in constants)):
            default = patch[0]
        fields.append(Field(fname, ftype, default))
    if len(fields) == 1 and fields[0].name == PLACEHOLDER_FIELD:
        fields = []
    return MessageDef(name, tuple(fields), constants, TYPESTORE_ORIGIN)
