"""One rosbridge client: its messages in, its bounded outbox out, its status messages.

Messages are read on the connection's thread and handed to the gateway's parts by ``op``;
whatever a part refuses (a missing field, a type that does not fit, a name not allowed) comes
back as a ``status`` message of level ``error`` naming the op (and its ``id``), as rosbridge
logs it. A client chooses which statuses it gets with ``set_level`` (``error`` by default, as
the rosbridge v2 protocol says).

What the client is sent goes through a :class:`~zros.gateway.common.send_queue.SendQueue` (bounded
in messages and in bytes) drained by a writer thread of its own: a client that reads slowly loses
its oldest messages (counted in the log and told with an ``error`` status, each at most once a
second) and never holds up the graph or the other clients.

What a client sends is bounded too: messages nested deeper than :data:`MAX_DEPTH`, fragments
past :data:`MAX_FRAGMENTS` or ``max_message_size`` bytes are refused with a status, and a
``fragment_size`` below :data:`MIN_FRAGMENT_SIZE` is raised to it (a ``warning`` status). A
read-only gateway refuses the ops that act on the robot (:data:`ACTING_OPS`).
"""

from __future__ import annotations

import collections
import itertools
import json
import logging
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from zros.errors import ZrosError
from zros.gateway.common.drop_notice import DropNotices
from zros.gateway.common.errors import GatewayError
from zros.gateway.common.json_types import int_field, text_field
from zros.gateway.common.send_queue import SendQueue
from zros.gateway.rosbridge.frames import Frames, encode, frames_size

if TYPE_CHECKING:
    from websockets.sync.server import ServerConnection

    from zros.cdr import JsonValue
    from zros.gateway.common.json_types import JsonObject, OutObject
    from zros.gateway.rosbridge.calls import Calls
    from zros.gateway.rosbridge.topics import Topics

_log = logging.getLogger('zros.gateway')

#: status levels, least severe first; a client gets those at or above its level
LEVELS = ('info', 'warning', 'error', 'none')
#: partially received fragmented messages a client may have at once
MAX_PARTIAL = 16
#: fragments a client may have received of messages not yet whole
MAX_FRAGMENTS = 100_000
#: the smallest ``fragment_size`` (smaller ones are raised to it)
MIN_FRAGMENT_SIZE = 1024
#: how deep a client's message may nest (arrays and objects)
MAX_DEPTH = 100
#: the ops a read-only gateway refuses (``call_service`` but for rosapi's reads)
ACTING_OPS = frozenset(
    ('advertise', 'publish', 'call_service', 'advertise_service', 'send_action_goal',
     'advertise_action')
)  # fmt: skip
_CONTAINERS = frozenset((dict, list))

#: the fields each op needs, and their JSON types (rosbridge's ``basic_type_check``)
_REQUIRED: dict[str, tuple[tuple[str, type | tuple[type, ...]], ...]] = {
    'advertise': (('topic', str), ('type', str)),
    'unadvertise': (('topic', str),),
    'publish': (('topic', str),),
    'subscribe': (('topic', str),),
    'unsubscribe': (('topic', str),),
    'call_service': (('service', str),),
    'advertise_service': (('service', str), ('type', str)),
    'unadvertise_service': (('service', str),),
    'service_response': (('service', str), ('result', bool)),
    'send_action_goal': (('action', str), ('action_type', str)),
    'cancel_action_goal': (('action', str),),
    'advertise_action': (('action', str), ('type', str)),
    'unadvertise_action': (('action', str),),
    'action_feedback': (('action', str), ('id', str)),
    'action_result': (('action', str), ('id', str), ('result', bool)),
    'set_level': (('level', str),),
    'fragment': (('id', (str, int)), ('data', str), ('num', int), ('total', int)),
}
_OPTIONAL: dict[str, type | tuple[type, ...]] = {
    'type': str,
    'throttle_rate': int,
    'queue_length': int,
    'fragment_size': (int, type(None)),
    'compression': str,
}


def too_deep(value: JsonValue, limit: int = MAX_DEPTH) -> bool:
    """Whether ``value`` nests arrays and objects more than ``limit`` deep (level by level,
    without recursion)."""
    level: list[JsonValue] = [value]
    for _ in range(limit):
        nested: list[JsonValue] = []
        for item in level:
            if isinstance(item, dict):
                items: Iterable[JsonValue] = item.values()
            elif isinstance(item, list):
                items = item
            else:
                continue
            if not _CONTAINERS.isdisjoint(map(type, items)):  # in C: a list of numbers is quick
                nested += [x for x in items if type(x) in _CONTAINERS]
        if not nested:
            return False
        level = nested
    return True


@dataclass
class _Partial:
    """The fragments of one message received so far."""

    total: int
    parts: dict[int, str] = field(default_factory=dict)
    size: int = 0  #: characters


def check_fields(op: str, message: JsonObject) -> None:
    """Refuse a message missing a field its op needs, or with a field of the wrong type."""
    for name, kind in _REQUIRED.get(op, ()):
        if name not in message:
            raise GatewayError(f'Expected a {name} field but none was found.')
        if not isinstance(message[name], kind) or (kind is int and isinstance(message[name], bool)):
            raise GatewayError(
                f'Expected field {name} to be one of {kind}. Invalid value: {message[name]!r}'
            )
    for name, kind in _OPTIONAL.items():
        value = message.get(name)
        if value is not None and (not isinstance(value, kind) or isinstance(value, bool)):
            raise GatewayError(
                f'Expected field {name} to be one of {kind}. Invalid value: {value!r}'
            )


class ClientSession:
    """A connected client (``connection`` is a websockets ``ServerConnection``)."""

    def __init__(
        self,
        client_id: int,
        connection: ServerConnection,
        topics: Topics,
        calls: Calls,
        *,
        max_message_size: int,
        queue_items: int,
        queue_bytes: int,
        read_only: bool = False,
    ) -> None:
        self.id = client_id
        self.connection = connection
        self._topics = topics
        self._calls = calls
        self.max_message_size = max_message_size
        self.read_only = read_only
        self.level = LEVELS.index('error')
        self.outbox: SendQueue[Frames] = SendQueue(queue_items, queue_bytes)
        self._notice: Frames | None = None  #: the status of the latest drops, to send first
        self._drops = DropNotices()
        self._partial: collections.OrderedDict[JsonValue, _Partial] = collections.OrderedDict()
        self._fragments = 0  #: fragments held in ``_partial``
        self._partial_size = 0  #: their characters
        self._ops: dict[str, Callable[[JsonObject], object]] = {
            'advertise': lambda m: topics.advertise(self, m),
            'unadvertise': lambda m: topics.unadvertise(self, m),
            'publish': lambda m: topics.publish(self, m),
            'subscribe': lambda m: topics.subscribe(self, m),
            'unsubscribe': lambda m: topics.unsubscribe(self, m),
            'call_service': lambda m: calls.call_service(self, m),
            'advertise_service': lambda m: calls.advertise_service(self, m),
            'unadvertise_service': lambda m: calls.unadvertise_service(self, m),
            'service_response': lambda m: calls.service_response(self, m),
            'send_action_goal': lambda m: calls.send_action_goal(self, m),
            'cancel_action_goal': lambda m: calls.cancel_action_goal(self, m),
            'advertise_action': lambda m: calls.served.advertise_action(self, m),
            'unadvertise_action': lambda m: calls.served.unadvertise_action(self, m),
            'action_feedback': lambda m: calls.served.action_feedback(self, m),
            'action_result': lambda m: calls.served.action_result(self, m),
            'set_level': self._set_level,
            'fragment': self._fragment,
        }
        self._writer = threading.Thread(
            target=self._write, name=f'zros rosbridge client {client_id}', daemon=True
        )

    def run(self) -> None:
        """Serve the client until it leaves (on the connection's thread)."""
        from websockets.exceptions import ConnectionClosed  # noqa: PLC0415 (optional: the rosbridge extra)

        self._writer.start()
        try:
            for raw in self.connection:
                self.incoming(raw)
        except ConnectionClosed as exc:
            _log.info('client %d: %s', self.id, exc)
        finally:
            self.close()

    # --- in ----------------------------------------------------------------------------------

    def incoming(self, raw: str | bytes, joined: bool = False) -> None:
        """Handle one message from the client (``joined``: put together from fragments)."""
        try:
            message = json.loads(raw)
        except UnicodeDecodeError:  # a binary frame: rosbridge_suite reads it as UTF-8 JSON too
            self.status(
                'error',
                f'a binary message of {len(raw)} bytes that is not JSON text (UTF-8) was '
                'dropped: rosbridge takes JSON, in text or binary frames (BSON is not served)',
            )
            return
        except ValueError as exc:
            self.status('error', f'a message that is not JSON was dropped: {exc}')
            return
        except RecursionError:  # deeper than Python's parser goes
            message = None
            deep = True
        else:
            deep = too_deep(message)
        if deep:
            self.status('error', f'a message nested deeper than {MAX_DEPTH} levels was dropped')
            return
        if not isinstance(message, dict):
            self.status(
                'error', f'a message that is not a JSON object was dropped: {str(raw)[:80]}'
            )
            return
        op, op_id = message.get('op'), message.get('id')
        handler = self._ops.get(op) if isinstance(op, str) else None
        if handler is None or not isinstance(op, str):
            if op is None:
                text = 'Received a message without an op.  All messages require'
                text += f" 'op' field with value one of: {list(self._ops)}."
            else:
                text = f'Unknown operation: {op}.  Allowed operations: {list(self._ops)}'
            self.status('error', text, op_id)
            return
        try:
            check_fields(op, message)
            if joined and op == 'fragment':
                raise GatewayError('fragments of fragments are not put together')
            self._check_fragment_size(op, message)
            if self.read_only and op in ACTING_OPS and not self._calls.reads(message):
                self._calls.refuse(self, message, 'this gateway is read-only (--read-only)')
                raise GatewayError('refused: this gateway is read-only (--read-only)')
            handler(message)
        except (GatewayError, ZrosError, ValueError, TypeError, KeyError) as exc:
            _log.debug('client %d: %s failed', self.id, op, exc_info=True)
            self.status('error', f'{op}: {exc}', op_id)

    def _check_fragment_size(self, op: str, message: JsonObject) -> None:
        size = message.get('fragment_size')
        if isinstance(size, int) and not isinstance(size, bool) and 0 < size < MIN_FRAGMENT_SIZE:
            message['fragment_size'] = MIN_FRAGMENT_SIZE
            self.status(
                'warning',
                f'{op}: fragment_size {size} is below {MIN_FRAGMENT_SIZE}: '
                f'{MIN_FRAGMENT_SIZE} is used',
                message.get('id'),
            )

    def _set_level(self, message: JsonObject) -> None:
        level = message['level']
        if level in LEVELS:
            self.level = LEVELS.index(level)

    def _fragment(self, message: JsonObject) -> None:
        """Put fragments back together, in time linear in their number (the fragments held
        are bounded by ``MAX_PARTIAL`` messages, ``MAX_FRAGMENTS`` and the message size)."""
        key, data = message['id'], text_field(message, 'data')
        total, num = int_field(message, 'total'), int_field(message, 'num')
        if not 0 <= num < total or total > MAX_FRAGMENTS:
            raise GatewayError(
                f'fragment {num} of {total} is out of range (at most {MAX_FRAGMENTS} fragments)'
            )
        partial = self._partial.get(key)
        if partial is not None and partial.total != total:  # a new message under an old id
            self._forget(key)
            partial = None
        if partial is None:
            partial = self._partial[key] = _Partial(total)
        self._partial.move_to_end(key)
        old = partial.parts.get(num)
        if old is not None:
            partial.size -= len(old)
            self._partial_size -= len(old)
            self._fragments -= 1
        partial.parts[num] = data
        partial.size += len(data)
        self._partial_size += len(data)
        self._fragments += 1
        if partial.size > self.max_message_size:
            self._forget(key)
            raise GatewayError(f'the fragments of {key!r} exceed {self.max_message_size} bytes')
        while len(self._partial) > 1 and (
            len(self._partial) > MAX_PARTIAL
            or self._partial_size > self.max_message_size
            or self._fragments > MAX_FRAGMENTS
        ):
            self._forget(next(iter(self._partial)))  # the stalest message goes first
        if len(partial.parts) == total:
            self._forget(key)
            self.incoming(''.join(partial.parts[n] for n in range(total)), joined=True)

    def _forget(self, key: JsonValue) -> None:
        partial = self._partial.pop(key)
        self._partial_size -= partial.size
        self._fragments -= len(partial.parts)

    # --- out ---------------------------------------------------------------------------------

    def send(self, message: OutObject, compression: str = 'none', fragment_size: int = 0) -> None:
        """Queue a protocol message (values in rosbridge's shapes) for the client."""
        size = self.max_message_size
        if fragment_size > 0:
            size = min(max(fragment_size, MIN_FRAGMENT_SIZE), size)
        try:
            frames = encode(message, compression, size)
        except (ValueError, TypeError) as exc:
            _log.error(
                'client %d: a %s message does not encode: %s', self.id, message.get('op'), exc
            )
            return
        self.send_frames(frames)

    def send_frames(self, frames: Frames) -> None:
        """Queue encoded frames (dropped with the oldest when the client falls behind)."""
        outbox = self.outbox
        outbox.put(frames, frames_size(frames))
        if outbox.dropped != self._drops.told:
            self._tell_drops()

    def status(self, level: str, text: str, op_id: JsonValue = None) -> None:
        """A status message, if the client wants this level (and a log line here)."""
        prefix = f'[client {self.id}]' + (f' [id: {op_id}]' if op_id is not None else '')
        _log.log(logging.WARNING if level == 'error' else logging.INFO, '%s %s', prefix, text)
        if LEVELS.index(level) >= self.level:
            status: JsonObject = {'op': 'status', 'level': level, 'msg': text}
            if op_id is not None:
                status['id'] = op_id
            self.send(status)

    def _tell_drops(self) -> None:
        """Log the drops and tell the client (:class:`DropNotices`: at most once a second)."""
        dropped = self.outbox.dropped
        new = self._drops.due(dropped)
        if new is None:
            return
        text = (
            f'this client reads too slowly: its oldest messages are being dropped '
            f'({new} more, {dropped} so far; room for {self.outbox.max_items} messages, '
            f'{self.outbox.max_bytes} bytes)'
        )
        _log.warning('[client %d] %s', self.id, text)
        if LEVELS.index('error') >= self.level:  # sent ahead of the queue: never dropped
            self._notice = encode({'op': 'status', 'level': 'error', 'msg': text})

    @property
    def dropped(self) -> int:
        """Messages dropped because the client read too slowly."""
        return self.outbox.dropped

    def _write(self) -> None:
        from websockets.exceptions import ConnectionClosed  # noqa: PLC0415 (optional: the rosbridge extra)

        send = self.connection.send
        while (frames := self.outbox.get()) is not None:
            notice, self._notice = self._notice, None
            try:
                for frame in itertools.chain(notice or (), frames):
                    send(frame)
            except ConnectionClosed:
                return

    # --- lifetime ----------------------------------------------------------------------------

    def close(self) -> None:
        """The client left: release what it held and stop its writer."""
        self.outbox.close()  # what was queued goes, uncopied
        if self.outbox.dropped:
            _log.info('[client %d] %d messages were dropped in all', self.id, self.outbox.dropped)
        try:
            self._topics.drop(self.id)
            self._calls.drop(self)
        finally:
            if self._writer.is_alive() and threading.current_thread() is not self._writer:
                self._writer.join(5.0)

    def __repr__(self) -> str:
        return f'<zros rosbridge client {self.id}>'
