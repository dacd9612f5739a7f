"""The key expressions and liveliness tokens of zenoh-bridge-ros2dds (bridge >= 1.0).

See ``shared/specs/bridge-protocol.md`` §1, §3 and §8. Everything here is a pure function of its
arguments. Token formatting refuses anything the bridge's parser would choke on: the bridge aborts
on out-of-range QoS numbers and on tokens it cannot slice (§3.3).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from zros.keyexpr.errors import TokenError
from zros.keyexpr.kinds import EntityKind
from zros.keyexpr.names import validate_full_name, validate_namespace
from zros.qos import Durability, History, QoS, Reliability

ESCAPE = '\u00a7'  # '§' stands for '/' inside one key chunk
TOKEN_PREFIX = '@ros2_lv'
#: liveliness selector of every entity token of every bridge (a '@' chunk never matches '**')
ENTITY_TOKENS = '@/*/@ros2_lv/**'
#: liveliness selector of the bridges' own tokens
BRIDGE_TOKENS = '@/*/@ros2_lv'
#: admin-space selectors answered by every bridge
VERSION_SELECTOR = '@/*/ros2/version'
CONFIG_SELECTOR = '@/*/ros2/config'

_TYPE_NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*/(msg|srv|action)/[A-Za-z][A-Za-z0-9_]*$')
_TYPE_HASH = re.compile(r'^RIHS01_[0-9a-f]{64}$')
_I32_MAX = 2**31 - 1


def escape(text: str) -> str:
    """One key chunk standing for a slash-separated string."""
    return text.replace('/', ESCAPE)


def unescape(chunk: str) -> str:
    """Undo the escaping of ``/`` in one chunk of a liveliness token."""
    return chunk.replace(ESCAPE, '/')


# --- names and keys --------------------------------------------------------------------------


def topic_key(ros_name: str, bridge_namespace: str = '/') -> str:
    """The Zenoh key of a fully qualified ROS name behind a bridge with ``bridge_namespace``.

    ``/chatter`` -> ``chatter``; with namespace ``/bot1``, ``/chatter`` -> ``bot1/chatter``.
    Services and actions use the same mapping (their name is the key prefix).
    """
    validate_full_name(ros_name)
    validate_namespace(bridge_namespace)
    if bridge_namespace == '/':
        return ros_name[1:]
    return bridge_namespace[1:] + ros_name


def ros_name(key: str, bridge_namespace: str = '/') -> str:
    """The ROS name a bridge gives a key it sees (the reverse of :func:`topic_key`).

    This reproduces the bridge exactly, including its plain string prefix test: with namespace
    ``/bot1`` the key ``bot10/x`` becomes ``0/x`` (not even a valid ROS name).
    """
    if bridge_namespace == '/':
        return '/' + key
    prefix = bridge_namespace[1:]
    if key.startswith(prefix):
        return key[len(prefix) :]
    return '/' + key


def action_key(action_key_prefix: str, part: str) -> str:
    """The key of one of an action's services or topics: ``<action>/_action/<part>``."""
    if part not in ('send_goal', 'cancel_goal', 'get_result', 'feedback', 'status'):
        raise ValueError(f'an action has no part {part!r}')
    return f'{action_key_prefix}/_action/{part}'


def admin_key(zid: str, item: str) -> str:
    """A key in a bridge's admin space: ``@/<zid>/ros2/<item>``."""
    return f'@/{zid}/ros2/{item}'


def dds_type_name(type_name: str) -> str:
    """The DDS type name the bridge creates for a ROS type (``pkg::msg::dds_::Name_``)."""
    package, kind, short = type_name.split('/')
    return f'{package}::{kind}::dds_::{short}_'


# --- the QoS chunk -----------------------------------------------------------------------------


@dataclass(frozen=True)
class TokenQoS:
    """The QoS chunk of an MP/MS token. ``None`` is a policy the token leaves unset."""

    reliability: Reliability | None = None
    durability: Durability | None = None
    history: History | None = None
    depth: int | None = None
    keyed: bool = False
    user_data: str | None = None  #: the optional 5th field (bridges >= 1.0.4)

    @classmethod
    def from_qos(cls, qos: QoS, type_hash: str | None = None) -> TokenQoS:
        """The chunk zros announces for ``qos`` (with ``typehash=`` when a hash is given)."""
        user_data = None
        if type_hash is not None:
            if not _TYPE_HASH.match(type_hash):
                raise TokenError(f'{type_hash!r} is not a RIHS01 type hash')
            user_data = f'typehash={type_hash};'
        return cls(qos.reliability, qos.durability, qos.history, qos.depth, False, user_data)

    @property
    def type_hash(self) -> str | None:
        """The RIHS01 hash in the user data, if any."""
        if self.user_data:
            for item in self.user_data.split(';'):
                name, _, value = item.partition('=')
                if name == 'typehash' and value:
                    return value
        return None

    def to_qos(self, writer: bool = True) -> QoS:
        """A full QoS, filling unset policies with the DDS defaults (which differ for readers)."""
        reliability = self.reliability
        if reliability is None:
            reliability = Reliability.RELIABLE if writer else Reliability.BEST_EFFORT
        durability = self.durability if self.durability is not None else Durability.VOLATILE
        if durability not in (Durability.VOLATILE, Durability.TRANSIENT_LOCAL):
            durability = Durability.TRANSIENT_LOCAL  # TRANSIENT and PERSISTENT keep at least this
        history = self.history if self.history is not None else History.KEEP_LAST
        depth = self.depth if self.depth is not None and self.depth >= 1 else 1
        return QoS(depth, reliability, durability, history)

    def format(self) -> str:
        """The chunk text, checked to be one the bridge parses safely."""
        fields = ['K' if self.keyed else '']
        fields.append('' if self.reliability is None else str(int(Reliability(self.reliability))))
        if self.durability is not None and int(self.durability) not in (0, 1):
            raise TokenError(f'durability {self.durability} is not one zros announces')
        fields.append('' if self.durability is None else str(int(self.durability)))
        if self.history is None:
            fields.append('')
        else:
            depth = self.depth if self.depth is not None else 1
            if not 1 <= depth <= _I32_MAX:
                raise TokenError(f'depth {depth} is outside 1..{_I32_MAX}')
            fields.append(f'{int(History(self.history))},{depth}')
        if self.user_data is not None:
            if '/' in self.user_data or ESCAPE in self.user_data:
                raise TokenError('the QoS user data must not contain "/"')
            fields.append(self.user_data)
        return ':'.join(fields)

    @classmethod
    def parse(cls, chunk: str) -> TokenQoS:
        """Parse a QoS chunk as the bridge writes it; TokenError when malformed."""
        fields = chunk.split(':')
        if len(fields) < 4:
            raise TokenError(f'QoS chunk {chunk!r} has {len(fields)} fields, expected 4 or 5')
        keyed, reliability, durability, history = fields[:4]
        user_data = ':'.join(fields[4:]) if len(fields) > 4 else None
        try:
            rel = Reliability(int(reliability)) if reliability else None
            dur_value = int(durability) if durability else None
            if dur_value is not None and not 0 <= dur_value <= 3:
                raise ValueError(durability)
            kind = depth = None
            if history:
                kind_text, _, depth_text = history.partition(',')
                kind = History(int(kind_text))
                depth = int(depth_text)
        except ValueError:
            raise TokenError(f'QoS chunk {chunk!r} has an invalid number') from None
        dur = None
        if dur_value is not None:
            dur = Durability(dur_value) if dur_value <= 1 else Durability.TRANSIENT_LOCAL
        return cls(rel, dur, kind, depth, bool(keyed), user_data)


# --- tokens ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class EntityToken:
    """One ROS entity announced on the Zenoh network by a bridge (or by zros)."""

    kind: EntityKind
    zid: str
    key: str  #: the Zenoh key of the topic, service or action (bridge namespace included)
    type_name: str  #: ``pkg/msg/Name``, ``pkg/srv/Name`` or ``pkg/action/Name``
    qos: TokenQoS | None = None  #: publishers and subscribers only

    def format(self) -> str:
        """The liveliness key of this token, refusing anything unsafe for a bridge."""
        if not re.fullmatch(r'[0-9a-f]+', self.zid):
            raise TokenError(f'zid {self.zid!r} is not a lowercase hex Zenoh id')
        _check_key(self.key)
        expected = {
            EntityKind.PUBLISHER: 'msg',
            EntityKind.SUBSCRIBER: 'msg',
            EntityKind.SERVICE_SERVER: 'srv',
            EntityKind.SERVICE_CLIENT: 'srv',
            EntityKind.ACTION_SERVER: 'action',
            EntityKind.ACTION_CLIENT: 'action',
        }[self.kind]
        match = _TYPE_NAME.match(self.type_name)
        if not match or match.group(1) != expected:
            raise TokenError(
                f'{self.kind.name} tokens need a pkg/{expected}/Name type, got {self.type_name!r}'
            )
        base = f'@/{self.zid}/{TOKEN_PREFIX}/{self.kind.value}/'
        base += f'{escape(self.key)}/{escape(self.type_name)}'
        if self.kind.has_qos:
            if self.qos is None:
                raise TokenError(f'{self.kind.name} tokens need a QoS')
            return f'{base}/{self.qos.format()}'
        return base

    @classmethod
    def parse(cls, token_key: str) -> EntityToken | None:
        """Parse a liveliness key under ``@/<zid>/@ros2_lv``; None for a bridge's own token."""
        parts = token_key.split('/')
        if len(parts) < 3 or parts[0] != '@' or parts[2] != TOKEN_PREFIX:
            raise TokenError(f'{token_key!r} is not a zenoh-bridge-ros2dds token')
        if len(parts) == 3:
            return None
        try:
            kind = EntityKind(parts[3])
        except ValueError:
            raise TokenError(f'{token_key!r} has an unknown entity kind {parts[3]!r}') from None
        expected = 7 if kind.has_qos else 6
        if len(parts) != expected:
            raise TokenError(f'{token_key!r} has {len(parts)} chunks, expected {expected}')
        qos = TokenQoS.parse(parts[6]) if kind.has_qos else None
        return cls(kind, parts[1], unescape(parts[4]), unescape(parts[5]), qos)


def _check_key(key: str) -> None:
    if not key or key.startswith('/') or key.endswith('/') or '//' in key:
        raise TokenError(f'{key!r} is not a valid Zenoh key')
    if any(char in key for char in '*$#?') or ESCAPE in key:
        raise TokenError(f'{key!r} holds a character zros never puts in a token key')


def bridge_zid(token_key: str) -> str | None:
    """The zid of a bridge's own token ``@/<zid>/@ros2_lv``, else None."""
    parts = token_key.split('/')
    if len(parts) == 3 and parts[0] == '@' and parts[2] == TOKEN_PREFIX:
        return parts[1]
    return None


class BridgeScheme:
    """Keys and tokens for reaching ROS 2 behind zenoh-bridge-ros2dds with ``namespace``.

    The type hash goes into MP/MS tokens only when ``send_type_hash`` is set: bridges before
    1.0.4 reject a fifth QoS field.
    """

    name = 'bridge'
    attachments = False  #: samples, requests and replies carry no attachment
    action_tokens = True  #: an action is announced by one AS/AC token, not by its parts

    def __init__(self, namespace: str = '/', send_type_hash: bool = False) -> None:
        validate_namespace(namespace)
        self.namespace = namespace
        self.send_type_hash = send_type_hash

    def key(self, ros_name: str) -> str:
        """The Zenoh key of a fully qualified topic, service or action name."""
        return topic_key(ros_name, self.namespace)

    def data_key(self, ros_name: str, type_name: str, type_hash: str | None) -> str:
        """The Zenoh key to declare entities on: the name's key (the type is not part of it)."""
        return self.key(ros_name)

    def node_token(self, zid: str, node_id: int, namespace: str, name: str) -> None:
        """Bridges have no node tokens (zros announces its nodes under ``@zros_lv``)."""
        return None

    def token(
        self,
        kind: EntityKind,
        zid: str,
        ros_name: str,
        type_name: str,
        *,
        qos: QoS | None = None,
        type_hash: str | None = None,
        node: object = None,
        entity_id: int | None = None,
    ) -> str:
        """The liveliness key announcing one entity to bridges (``node`` and ``entity_id`` are
        for schemes whose tokens name them)."""
        token_qos = None
        if kind.has_qos:
            token_qos = TokenQoS.from_qos(qos or QoS(), type_hash if self.send_type_hash else None)
        return EntityToken(kind, zid, self.key(ros_name), type_name, token_qos).format()

    def __repr__(self) -> str:
        return f'<BridgeScheme namespace={self.namespace!r}>'
