"""The wire formats of zenoh-bridge-ros2dds 1.x, written from ``shared/specs/bridge-protocol.md``.

Pure functions and data classes: no rclpy, no zenoh, and on purpose no zros (a mistake in zros's
key code must not be mirrored here). Section numbers refer to the spec.
"""

from __future__ import annotations

import enum
import json
import re
import struct
from dataclasses import dataclass

ESCAPE = '\u00a7'  # '§' replaces '/' inside the ke and type chunks (§3.1)
LV = '@ros2_lv'
#: liveliness selector of every bridge's tokens (plugin tokens included: '**' matches no chunk)
TOKENS_SELECTOR = '@/*/@ros2_lv/**'
I32_MAX = 2**31 - 1

#: CycloneDDS enum values used in the QoS chunk (§3.2)
BEST_EFFORT, RELIABLE = 0, 1
VOLATILE, TRANSIENT_LOCAL, TRANSIENT, PERSISTENT = 0, 1, 2, 3
KEEP_LAST, KEEP_ALL = 0, 1

_ROS_NAME = re.compile(r'^(/[A-Za-z_][A-Za-z0-9_]*)+$|^/$')
_NAMESPACE = re.compile(r'^/[A-Za-z0-9_/]*$')
_NODE_NAME = re.compile(r'^[A-Za-z0-9_]+$')
_PKG_TYPE = re.compile(r'^[A-Za-z][A-Za-z0-9_]*/(msg|srv|action)/[A-Za-z][A-Za-z0-9_]*$')


class TokenError(ValueError):
    """A liveliness token the bridge would not turn into a route (or would crash on)."""


class Kind(str, enum.Enum):
    """The six entity kinds of §3.1 and the interface kind each one's type must have."""

    MP = 'MP'
    MS = 'MS'
    SS = 'SS'
    SC = 'SC'
    AS = 'AS'
    AC = 'AC'

    @property
    def has_qos(self) -> bool:
        return self in (Kind.MP, Kind.MS)

    @property
    def interface(self) -> str:
        return {'M': 'msg', 'S': 'srv', 'A': 'action'}[self.value[0]]


def escape(text: str) -> str:
    return text.replace('/', ESCAPE)


def unescape(chunk: str) -> str:
    return chunk.replace(ESCAPE, '/')


# --- §1 names and keys ------------------------------------------------------------------------


def check_namespace(namespace: str) -> None:
    """The bridge's own check of its ``namespace`` config (``lib.rs`` : ``run``)."""
    if not _NAMESPACE.match(namespace) or (namespace != '/' and namespace.endswith('/')):
        raise ValueError(f'invalid bridge namespace {namespace!r}')


def check_nodename(nodename: str) -> None:
    if not _NODE_NAME.match(nodename):
        raise ValueError(f'invalid bridge nodename {nodename!r}')


def is_ros_name(name: str) -> bool:
    """Whether ``name`` is a fully qualified ROS name (what rcl accepts for a topic)."""
    return name != '/' and bool(_ROS_NAME.match(name))


def ros_to_key(ros_name: str, namespace: str = '/') -> str:
    """``/chatter`` -> ``chatter``, or ``bot1/chatter`` behind a bridge with namespace ``/bot1``."""
    if not ros_name.startswith('/'):
        raise ValueError(f'{ros_name!r} is not a fully qualified ROS name')
    if namespace == '/':
        return ros_name[1:]
    return namespace[1:] + ros_name


def key_to_ros(key: str, namespace: str = '/') -> str:
    """The ROS name the bridge gives a key announced by others.

    Reproduces the bridge's plain string prefix test: with namespace ``/bot1`` the key
    ``bot10/x`` becomes ``0/x``, which is no ROS name (creating a DDS entity on it then fails).
    """
    if namespace == '/':
        return '/' + key
    prefix = namespace[1:]
    if key.startswith(prefix):
        return key[len(prefix) :]
    return '/' + key


def check_key(key: str) -> None:
    """A key the bridge can declare publishers/subscribers on: no wildcard, no empty chunk."""
    if not key or key.startswith('/') or key.endswith('/') or '//' in key:
        raise TokenError(f'{key!r} is not a valid Zenoh key')
    for chunk in key.split('/'):
        if chunk in ('*', '**') or '*' in chunk or '$' in chunk or '#' in chunk or '?' in chunk:
            raise TokenError(f'{key!r} is a wildcard or holds a forbidden character')


def dds_type(type_name: str) -> str:
    """``std_msgs/msg/String`` -> ``std_msgs::msg::dds_::String_`` (§4 Type names)."""
    package, kind, short = type_name.split('/')
    return f'{package}::{kind}::dds_::{short}_'


# --- §3.2 the QoS chunk -----------------------------------------------------------------------


@dataclass(frozen=True)
class TokenQos:
    """The QoS chunk of an MP/MS token; ``None`` is a policy left unset (DDS default applies)."""

    keyed: bool = False
    reliability: int | None = None
    durability: int | None = None
    history: int | None = None
    depth: int | None = None
    user_data: str | None = None

    def to_chunk(self) -> str:
        fields = [
            'K' if self.keyed else '',
            '' if self.reliability is None else str(self.reliability),
            '' if self.durability is None else str(self.durability),
            '' if self.history is None else f'{self.history},{self.depth}',
        ]
        if self.user_data is not None:
            fields.append(self.user_data)
        return ':'.join(fields)

    @classmethod
    def parse(cls, chunk: str) -> TokenQos:
        """Parse a chunk; TokenError for what the bridge rejects or panics on."""
        fields = chunk.split(':', 4)
        if len(fields) < 4:
            raise TokenError(f'QoS {chunk!r}: {len(fields)} fields, the bridge needs 4 or 5')
        keyed, rel, dur, hist = fields[:4]
        user_data = fields[4] if len(fields) == 5 else None
        # The real bridge panics (and aborts, panic = "abort") on out-of-range numbers: the
        # cyclors From<i32> impls of ReliabilityKind/DurabilityKind/HistoryKind do not accept them.
        reliability = _number(chunk, 'reliability', rel, (BEST_EFFORT, RELIABLE))
        durability = _number(
            chunk, 'durability', dur, (VOLATILE, TRANSIENT_LOCAL, TRANSIENT, PERSISTENT)
        )
        history = depth = None
        if hist:
            kind_text, comma, depth_text = hist.partition(',')
            if not comma:
                raise TokenError(f'QoS {chunk!r}: history {hist!r} is not KIND,DEPTH')
            history = _number(chunk, 'history kind', kind_text, (KEEP_LAST, KEEP_ALL))
            if not re.fullmatch(r'-?[0-9]+', depth_text):
                raise TokenError(f'QoS {chunk!r}: depth {depth_text!r} is not a number')
            depth = int(depth_text)
            if not -(2**31) <= depth <= I32_MAX:
                raise TokenError(f'QoS {chunk!r}: depth {depth} is not an i32')
            # The real bridge passes this on to CycloneDDS, which refuses the entity (the route
            # is half made and never works).
            if history == KEEP_LAST and depth < 1:
                raise TokenError(f'QoS {chunk!r}: keep-last needs depth >= 1')
        return cls(bool(keyed), reliability, durability, history, depth, user_data)


def _number(chunk: str, what: str, text: str, allowed: tuple[int, ...]) -> int | None:
    if text == '':
        return None
    if not re.fullmatch(r'[0-9]+', text):
        raise TokenError(f'QoS {chunk!r}: {what} {text!r} is not a number')
    value = int(text)
    if value not in allowed:
        raise TokenError(f'QoS {chunk!r}: {what} {value} is out of range')
    return value


# --- §3.1 tokens ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Token:
    """One entity token ``@/<zid>/@ros2_lv/<kind>/<esc ke>/<esc type>[/<qos>]``."""

    zid: str
    kind: Kind
    key: str
    type_name: str
    qos: TokenQos | None = None

    def to_key(self) -> str:
        base = f'@/{self.zid}/{LV}/{self.kind.value}/{escape(self.key)}/{escape(self.type_name)}'
        if self.kind.has_qos:
            return f'{base}/{(self.qos or TokenQos()).to_chunk()}'
        return base

    @property
    def remote_route(self) -> str:
        """How the bridge keys a remote announcement: ``"<zid>:<ke>"`` (§3.3)."""
        return f'{self.zid}:{self.key}'


def plugin_token(zid: str) -> str:
    return f'@/{zid}/{LV}'


def parse_token(key: str) -> Token | str:
    """A Token, or the zid of a plugin token ``@/<zid>/@ros2_lv``; TokenError when malformed."""
    if not key.startswith('@/'):
        raise TokenError(f'{key!r} is not under @/<zid>/')
    zid, sep, rest = key[2:].partition('/')
    if not zid or not sep or not rest.startswith(LV):
        raise TokenError(f'{key!r} is not a zenoh-bridge-ros2dds token')
    rest = rest[len(LV) :]
    if rest == '':
        return zid
    if not rest.startswith('/'):
        raise TokenError(f'{key!r} is not a zenoh-bridge-ros2dds token')
    rest = rest[1:]
    # The real bridge slices the first 3 bytes of the remainder (lib.rs): a remainder shorter
    # than 3 bytes, or one with a multibyte character there, panics and aborts the bridge.
    head = rest.encode()[:3]
    if len(head) < 3:
        raise TokenError(f'{key!r}: remainder {rest!r} is shorter than "XX/" (bridge panics)')
    try:
        head.decode('ascii')
    except UnicodeDecodeError:
        raise TokenError(f'{key!r}: non-ASCII kind (the bridge panics slicing it)') from None
    chunks = rest.split('/')
    try:
        kind = Kind(chunks[0])
    except ValueError:
        raise TokenError(f'{key!r}: unknown entity kind {chunks[0]!r}') from None
    expected = 4 if kind.has_qos else 3
    if len(chunks) != expected:
        raise TokenError(f'{key!r}: {kind.value} tokens have {expected} chunks after @ros2_lv')
    ke, type_name = unescape(chunks[1]), unescape(chunks[2])
    check_key(ke)
    # The real bridge does not check the type: it creates a DDS entity with the mangled name,
    # which then matches nothing on the ROS side. Rejecting it here makes the mistake visible.
    match = _PKG_TYPE.match(type_name)
    if not match or match.group(1) != kind.interface:
        raise TokenError(f'{key!r}: {type_name!r} is not pkg/{kind.interface}/Name')
    qos = TokenQos.parse(chunks[3]) if kind.has_qos else None
    return Token(zid, kind, ke, type_name, qos)


# --- §8 admin space ---------------------------------------------------------------------------


def admin_prefix(zid: str) -> str:
    return f'@/{zid}/ros2'


def version_json(version: str) -> str:
    """The ``@/<zid>/ros2/version`` reply: a JSON string ``"v<semver>"``."""
    return json.dumps(f'v{version}')


def config_json(namespace: str, nodename: str, domain: int) -> str:
    """The ``@/<zid>/ros2/config`` reply, with the defaults of the keys tests may read."""
    return json.dumps(
        {
            'namespace': namespace,
            'nodename': nodename,
            'domain': domain,
            'ros_localhost_only': False,
            'reliable_routes_blocking': True,
            'transient_local_cache_multiplier': 10,
            'queries_timeout': {'default': 5.0},
        }
    )


# --- §5 services ------------------------------------------------------------------------------

RQH = b'rqh'
#: ``queries_timeout`` defaults of the bridge config (seconds)
SERVICE_TIMEOUT = 5.0
GET_RESULT_TIMEOUT = 300.0


def request_header_attachment(guid: int, sequence: int, little_endian: bool = True) -> bytes:
    """The 20-byte "rqh" attachment: ``rqh`` + GUID u64 + seq i64 (sample byte order) + 1 byte
    (``01`` little-endian, ``00`` big-endian)."""
    order = '<' if little_endian else '>'
    return RQH + struct.pack(f'{order}Qq', guid, sequence) + (b'\x01' if little_endian else b'\x00')


def parse_request_header(attachment: bytes | None) -> tuple[int, int, bool] | None:
    """(guid, sequence, little_endian) of a well-formed "rqh" attachment, else None."""
    if attachment is None or len(attachment) != 20 or attachment[:3] != RQH:
        return None
    if attachment[19] not in (0, 1):
        return None
    little = attachment[19] == 1
    guid, sequence = struct.unpack('<Qq' if little else '>Qq', attachment[3:19])
    return guid, sequence, little


def valid_service_payload(payload: bytes) -> bool:
    """The bridge's check on requests and replies: a CDR header whose byte 1 is 0 or 1."""
    return len(payload) >= 4 and payload[1] <= 1


# --- §6 actions -------------------------------------------------------------------------------

ACTION_SERVICES = ('send_goal', 'cancel_goal', 'get_result')
ACTION_TOPICS = ('feedback', 'status')


def action_key(key: str, part: str) -> str:
    """``fibonacci`` + ``send_goal`` -> ``fibonacci/_action/send_goal``."""
    if part not in ACTION_SERVICES + ACTION_TOPICS:
        raise ValueError(f'an action has no part {part!r}')
    return f'{key}/_action/{part}'


def action_part_type(type_name: str, part: str) -> str:
    """The ROS type of one part of the action ``pkg/action/Name`` (table of §6)."""
    return {
        'send_goal': f'{type_name}_SendGoal',
        'cancel_goal': 'action_msgs/srv/CancelGoal',
        'get_result': f'{type_name}_GetResult',
        'feedback': f'{type_name}_FeedbackMessage',
        'status': 'action_msgs/msg/GoalStatusArray',
    }[part]


#: QoS of the action topics (QOS_DEFAULT_ACTION_FEEDBACK / _STATUS)
ACTION_FEEDBACK_QOS = TokenQos(False, RELIABLE, VOLATILE, KEEP_LAST, 10)
ACTION_STATUS_QOS = TokenQos(False, RELIABLE, TRANSIENT_LOCAL, KEEP_LAST, 1)
